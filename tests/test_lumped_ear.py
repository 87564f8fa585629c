"""The lumped ossicular chain (lumped/ear.py) against the FE whole ear, and ``isj ear sweep``.

Tolerances are measured, with margin, not tuned (default anatomy, per Pa):

- rigid joint, lumped vs ``MiddleEarModel(joint=None)``: umbo and stapes agree to 2e-6
  (the drum's condensation is exact; what is left is the footplate's flexibility and
  the shipped parameters' 8 digits): tolerance 1e-3;
- embedded joint on the coarse mesh (P2, resolution 0.35), lumped (calibrated joint) vs FE:
  umbo −1.6 %, stapes +0.9 %, β −2.7 %, α −3.2 % (the lumped coupling has no axial
  compliance, and the calibration was fitted at resolution 1): tolerances 3 % (umbo,
  stapes, β) and 10 % (α);
- the one-dof body (rotation about the nominal axis): umbo −16.7 %, stapes −13.9 %: the
  FE body's axis tilts and moves; documented, not a pass.
- frequency response, rigid joint, docs/dynamics.md §4.3 damping (b = 1e-4 s), same masses
  (:class:`isj.ear.EarMasses`), lumped / FE − 1 for |umbo|, |stapes| and the phase difference:
  100, 300 Hz: < 1e-4, 0.00°; 800 Hz: −0.16 %, +0.18°; 1.2 kHz: +0.37 %, +0.97°;
  1656 Hz (FE f1): +4.6 %, +1.4°; 2 kHz: +8.1 %, −0.6°; 3 kHz: +4.4 %, −6.9°;
  5 kHz: −9.9 %, −7.5°. The FE's lowest modes (1656, 1902, 2017 Hz, ...) are eardrum
  modes (93–99 % of their kinetic energy in the drum), which the lumped drum's one
  uncoupled shape cannot represent; the lumped first natural frequency, 1993 Hz, is 20 %
  above the FE's 1656 Hz. The heavy Rayleigh damping (ζ = πfb = 0.52 at 1656 Hz) smooths
  the difference. Tolerances: 5e-3 and 0.5° below 0.5 f1 (FE), 12 % and 3° from 0.7 to 1.2
  f1, 15 % and 10° up to 5 kHz (a documented bound, not an agreement).
"""

import dataclasses
import json

import gmsh  # noqa: F401 - a hard dependency: without it these tests fail, they do not skip
import numpy as np
import pytest
from isj.lumped.ear import DEFAULT_EARDRUM, OUTPUTS, EardrumParameters, ear_model

from isj.ear import EarMaterials
from isj.errors import InvalidParameter


@pytest.fixture(scope="module")
def rigid_fe():
    from isj.fem.ear.middle_ear import MiddleEarModel

    return MiddleEarModel()


@pytest.fixture(scope="module")
def rigid_fe_result(rigid_fe):
    return rigid_fe.static()


def _rel(a, b):
    return abs(a / b - 1)


def test_shipped_eardrum_parameters_are_the_fe_drums():
    from isj.fem.ear.lumped_params import eardrum_parameters

    d = eardrum_parameters()
    fresh = EardrumParameters.from_dict(d)
    for f in ("load_per_pa", "stiffness", "mass", "cross_mass"):
        a, b = np.asarray(getattr(fresh, f)), np.asarray(getattr(DEFAULT_EARDRUM, f))
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-7 * np.abs(a).max(), err_msg=f)
    for f in ("compliance_m3_per_pa", "uncoupled_mass_kg_m4", "drum_mass_kg"):
        assert getattr(DEFAULT_EARDRUM, f) == pytest.approx(getattr(fresh, f), rel=1e-6)
    # the figures DEFAULT_EARDRUM's comment states, on the nominal axis, referred to the umbo
    assert d["area_m2"] == pytest.approx(22.1e-6, rel=5e-3)
    assert d["stiffness_n_m"] == pytest.approx(371.0, rel=5e-3)


def test_rigid_joint_static_equals_fe(rigid_fe_result):
    fe = rigid_fe_result
    y = ear_model(rigid_joint=True).static().outputs
    assert _rel(y[0], fe.umbo_m_per_pa) < 1e-3
    assert _rel(y[1], fe.footplate_piston_m_per_pa) < 1e-3
    assert y[2] == y[3] == 0.0


def test_drum_modulus_rescaling_matches_fe(rigid_fe):
    mat = EarMaterials(drum_e_pa=40e6)
    fe = rigid_fe.static(ear_materials=mat)
    y = ear_model(rigid_joint=True, ear_materials=mat).static().outputs
    assert _rel(y[0], fe.umbo_m_per_pa) < 1e-3
    assert _rel(y[1], fe.footplate_piston_m_per_pa) < 1e-3


def test_one_dof_body_is_documented_low(rigid_fe_result):
    fe = rigid_fe_result
    y = ear_model(rigid_joint=True, body="rotation").static().outputs
    assert 0.10 < 1 - y[0] / fe.umbo_m_per_pa < 0.25
    assert 0.08 < 1 - y[1] / fe.footplate_piston_m_per_pa < 0.25


def test_embedded_joint_static_against_fe(coarse_model):
    from isj.fem.ear.middle_ear import MiddleEarModel

    fe = MiddleEarModel(joint=coarse_model).static()
    y = ear_model().static().outputs
    assert _rel(y[0], fe.umbo_m_per_pa) < 0.03
    assert _rel(y[1], fe.footplate_piston_m_per_pa) < 0.03
    assert _rel(y[2], fe.alpha_rad_per_pa) < 0.10
    assert _rel(y[3], fe.beta_rad_per_pa) < 0.03


def test_static_limit_is_the_static_solve():
    for kw in ({}, {"rigid_joint": True}, {"body": "rotation"}):
        ear = ear_model(damping="undamped", **kw)
        h0 = ear._freq_resp([0.0])[0]
        np.testing.assert_allclose(h0.real, ear.static().outputs, rtol=1e-12, atol=0)
        assert np.all(h0.imag == 0)


def test_massless_response_is_flat():
    ear = ear_model(damping="uniform-rayleigh")  # the old convention: b = 1e-4 s on every part
    s = ear.system
    flat = dataclasses.replace(ear, system=dataclasses.replace(s, M=0 * s.M, E=0 * s.E))
    H = flat._freq_resp(np.geomspace(10, 1e5, 30))
    np.testing.assert_allclose(H, np.broadcast_to(ear.static().outputs, H.shape), rtol=1e-10)
    # and with masses, the response rolls off above the first resonance
    f_n, zeta = ear.system.poles()
    assert np.all(np.diff(f_n) >= 0) and 1e3 < f_n[0] < 5e3
    np.testing.assert_allclose(zeta, np.pi * f_n * 1e-4, rtol=1e-8)  # Rayleigh b = 1e-4 s
    assert abs(ear._freq_resp([5 * f_n[0]])[0, 0]) < 0.2 * ear.static().outputs[0]


def test_linear_in_pressure():
    ear = ear_model()
    f = np.geomspace(100, 20e3, 7)
    np.testing.assert_allclose(ear.static(2.828).outputs, 2.828 * ear.static().outputs, rtol=1e-14)
    np.testing.assert_allclose(ear._freq_resp(f, 2.828), 2.828 * ear._freq_resp(f), rtol=1e-14)


def test_vectorised_over_designs_equals_one_at_a_time():
    gap = np.array([2e6, 5e6, 10e6, 40e6])
    ped = np.array([3e9, 12e9, 20e9, 8e9])
    f = np.geomspace(100, 20e3, 9)
    many = ear_model(gap_e_pa=gap, pedicle_e_pa=ped)
    H, S = many._freq_resp(f), many.static().outputs
    assert H.shape == (4, 9, len(OUTPUTS)) and S.shape == (4, len(OUTPUTS))
    for i in range(4):
        one = ear_model(gap_e_pa=float(gap[i]), pedicle_e_pa=float(ped[i]))
        np.testing.assert_allclose(H[i], one._freq_resp(f), rtol=1e-12)
        np.testing.assert_allclose(S[i], one.static().outputs, rtol=1e-12)
    # a stiffer gap: a smaller alpha
    assert np.argmin(S[:, 2]) == np.argmax(gap)


@pytest.mark.parametrize(
    "kw",
    [
        {"body": "free"},
        {"rayleigh_b_s": -1.0},
        {"loss_factor": float("nan")},
        {"gap_e_pa": -1.0},
    ],
)
def test_bad_parameters(kw):
    with pytest.raises(InvalidParameter):
        ear_model(**kw)


def test_bad_frequency():
    with pytest.raises(InvalidParameter, match="freq_hz"):
        ear_model()._freq_resp([-1.0])


# ---------------------------------------------------------------- isj ear sweep


@pytest.mark.slow
def test_cli_ear_sweep_rigid(tmp_path, capsys):
    from isj.cli import main

    out = tmp_path / "s"
    argv = ["ear", "sweep", "--rigid-joint", "--n", "40", "--fmax-hz", "5000", "--out", str(out), "--json"]
    # the old uniform damping, which the 3 % below holds for: with the published loss factors the
    # lumped drum's single shape misses the FE drum's first mode (1.66 kHz) by 7.7 % at 1.36 kHz
    argv += ["--damping", "uniform-rayleigh"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["passed"] and summary["fe_check"]["umbo_m_rel_error"] < 1e-3
    checks = summary["fe_checks"]  # default 2, log-spaced inside 100 Hz–5 kHz: 368 Hz and 1.36 kHz
    assert [round(c["freq_hz"]) for c in checks] == [368, 1357]
    assert all(c["passed"] and c["umbo_m_rel_error"] < 0.03 and len(c["fe_stapes_m"]) == 2 for c in checks)
    assert sorted(p.name for p in out.iterdir()) == [
        "ear_bode.png",
        "ear_sweep.csv",
        "ear_sweep.json",
        "ear_sweep.npz",
    ]
    lines = (out / "ear_sweep.csv").read_text().splitlines()
    assert lines[0].startswith("# units: freq_hz Hz; umbo_m, stapes_m m per Pa")
    assert len(lines) == 2 + 40
    npz = np.load(out / "ear_sweep.npz")
    assert npz["response_per_pa"].shape == (40, 4)
    rec = json.loads((out / "ear_sweep.json").read_text())
    assert rec["results"]["n_freq"] == 40
    # a tolerance the spot check cannot meet: exit 1, files still written
    assert main(["ear", "sweep", "--rigid-joint", "--n", "5", "--out", str(out), "--tolerance", "1e-9"]) == 1
    capsys.readouterr()
    # the default band (100 Hz–5 kHz, the drum with 40 component modes) passes its checks
    assert main(["ear", "sweep", "--rigid-joint", "--n", "5", "--out", str(out), "--json"]) == 0
    capsys.readouterr()
    # 100 Hz–20 kHz with the drum's one static shape (--drum-modes 0): the static check and the
    # 585 Hz check pass, the 3.42 kHz one does not (complex error 14 % for the umbo, 13 % for the
    # stapes: above the FE's eardrum modes the one shape is off, documented above): exit 1
    argv = ["ear", "sweep", "--rigid-joint", "--n", "5", "--fmax-hz", "20000", "--out", str(out), "--json"]
    assert main([*argv, "--drum-modes", "0", "--damping", "uniform-rayleigh"]) == 1
    summary = json.loads(capsys.readouterr().out)
    assert summary["drum_modes"] == 0
    assert summary["fe_check"]["passed"] and summary["fe_checks"][0]["passed"]
    assert summary["fe_checks"][1]["umbo_m_rel_error"] == pytest.approx(0.14, abs=0.02)
    # with the default 40 component modes of the drum (to 6.1 kHz) the same checks hold within 1 %,
    # with the published damping (measured 0.6 % at 3.42 kHz)
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["drum_modes"] == 40 and summary["passed"]
    assert max(summary["fe_checks"][1][f"{k}_rel_error"] for k in ("umbo_m", "stapes_m")) < 0.01


@pytest.mark.slow
def test_cli_ear_sweep_coarse_joint(tmp_path, capsys):
    from isj.cli import main

    out = tmp_path / "j"
    argv = ["ear", "sweep", "--resolution", "0.35", "--n", "20", "--fmax-hz", "5000", "--out", str(out)]
    rc = main([*argv, "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert rc == 0 and summary["passed"]
    assert summary["fe_check"]["stapes_m_rel_error"] < 0.03
    assert "alpha" in summary["coordinates"]


@pytest.mark.parametrize(
    "argv",
    [
        ["--fmin-hz", "1000", "--fmax-hz", "100"],
        ["--fmin-hz", "-5"],
        ["--n", "1"],
        ["--fe-checks", "-1"],
        ["--fe-checks", "51"],
        ["--tolerance", "-0.1"],
        ["--gap-e", "0"],
        ["--drum-e", "nan"],
    ],
)
def test_cli_ear_sweep_bad_input(tmp_path, capsys, argv):
    from isj.cli import main

    out = tmp_path / "bad"
    assert main(["ear", "sweep", "--rigid-joint", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("isj: error:") and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.filterwarnings("ignore::isj.errors.DampingWarning")
def test_rigid_joint_frequency_response_against_fe(rigid_fe):
    f1_fe = rigid_fe.natural_frequencies_hz(1)[0]
    assert f1_fe == pytest.approx(1656, rel=0.01)
    lumped = ear_model(rigid_joint=True, damping="uniform-rayleigh")  # the tolerances' damping
    f1_lumped = lumped.natural_frequencies_hz()[0]
    assert f1_lumped / f1_fe == pytest.approx(1.203, abs=0.02)  # documented: drum modes in the FE
    bands = (  # (frequencies as fractions of f1 or Hz, |H| tolerance, phase tolerance in degrees)
        (np.array([100.0, 300.0, 0.5 * f1_fe]), 5e-3, 0.5),
        (np.array([0.7, 1.0, 1.2]) * f1_fe, 0.12, 3.0),
        (np.array([3e3, 5e3]), 0.15, 10.0),
    )
    for freq, tol_mag, tol_deg in bands:
        fe = rigid_fe.frequency_response(freq, damping="uniform-rayleigh").response[..., 0][:, :2]
        lum = lumped._freq_resp(freq)[:, :2]
        ratio = lum / fe
        assert np.all(np.abs(np.abs(ratio) - 1) <= tol_mag), (freq, np.abs(ratio) - 1)
        assert np.all(np.abs(np.degrees(np.angle(ratio))) <= tol_deg), (freq, np.degrees(np.angle(ratio)))
