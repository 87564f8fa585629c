"""The lumped model's sliding joint (docs/lumped.md §3.14): FE settings and cache keys carry the joint,
the shipped sliding calibration, ``LumpedModel(joint=...)`` and ``isj lumped solve --joint``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from isj.calibration.doe import sample
from isj.calibration.pipeline import calibrate_dynamics, error_stats, records_for_fit, settings_joint
from isj.calibration.runner import design_key, run_designs
from isj.fem import batch
from isj.lumped.api import LumpedModel
from isj.lumped.artifact import Calibration, default_calibration, sliding_calibration
from isj.lumped.model import MODULI

from isj.cases import THESIS_CASES
from isj.design import Materials
from isj.design_space import DesignSpace
from isj.errors import CorruptCalibration, InvalidParameter

#: FE α and β (µrad) of the seven thesis cases, bonded and sliding, at the default pressure, P2 on
#: the default mesh (resolution 1): the table of docs/model.md §2.12 (isj.fem.model.compare_cases).
FE_CASES_URAD = {
    #        bonded α, β       sliding α, β
    "base": ((1.708, 11.41), (1.702, 11.43)),
    "j5": ((2.431, 11.49), (2.434, 11.50)),
    "c20": ((2.106, 11.37), (2.124, 11.38)),
    "c100": ((1.359, 11.45), (1.345, 11.47)),
    "j5c20": ((3.417, 11.43), (3.468, 11.44)),
    "p12": ((1.703, 7.48), (1.698, 7.50)),
    "p3": ((1.711, 15.86), (1.706, 15.88)),
}

COARSE = {"order": 1, "resolution": 0.35}

#: The bonded calibration fitted like the sliding one (least squares on the same 128 Sobol' designs,
#: seed 0, P2, resolution 1): lumped/data/default_calibration.json at 4211de0^ (format 3, shipped
#: until the adaptive format-5 one replaced it; ``root_plate`` and ``pedicle_face`` absent, 0).
LIKE_FOR_LIKE_BONDED = {
    "pedicle_bending": 0.9818618869125215,
    "pedicle_root": 5.176428129244652,
    "pedicle_top": 2.9633531293425284,
    "root_foundation": 0.06752188983383768,
    "gap": 1.2332578064919701,
    "capsule": 0.45057074575182776,
    "attachment_plate": 0.07119442369789107,
    "attachment_stapes": 0.2210446599043687,
    "plate_bulk": 6.799652456323045,
    "stapes_bulk": 0.3397944443619824,
    "plate_support": 0.05207451161127774,
    "load_sharing": 4.564466488602948,
}


@pytest.fixture
def run_cli(capsys):
    """``isj ARGS...`` in this process: (exit code, stdout, stderr)."""
    from isj.cli import main

    def run(*argv):
        code = main(list(argv))
        out, err = capsys.readouterr()
        return code, out, err

    return run


# ---- FE settings and the result cache ------------------------------------------------------


def test_fe_settings_carry_the_joint():
    bonded, sliding = batch.fe_settings(**COARSE), batch.fe_settings(**COARSE, joint="sliding")
    assert "joint" not in bonded  # bonded settings (and keys) are those of before the joint existed
    assert sliding["joint"] == "sliding"
    assert settings_joint(bonded) == "bonded" and settings_joint(sliding) == "sliding"
    design = {"gap_e_pa": 1e7}
    assert design_key(design, bonded) != design_key(design, sliding)
    with pytest.raises(InvalidParameter, match="joint"):
        batch.fe_settings(joint="layer")  # no layer shear modulus in the settings
    with pytest.raises(InvalidParameter, match="joint"):
        batch.evaluate_design(design, dict(bonded, joint="glued"))


def test_bonded_and_sliding_never_share_a_cache_entry(tmp_path):
    """One design, both joints, one cache: two records, each the FE model of its own joint."""
    from isj.fem.model import PedicleJointModel

    design = {"gap_e_pa": 5e6, "capsule_e_pa": 2e7}  # a soft capsule: the joint matters (c20-like)
    settings = {j: batch.fe_settings(**COARSE, joint=j) for j in ("bonded", "sliding")}
    recs = {
        j: run_designs([design], batch.evaluate_design, s, tmp_path, max_workers=0, progress=False)[0]
        for j, s in settings.items()
    }
    assert recs["bonded"]["key"] != recs["sliding"]["key"]
    assert len(list(tmp_path.glob("*.json"))) == 2
    # each record is its joint's FE model, bit for bit (the joint reached the model)
    for j, rec in recs.items():
        model = PedicleJointModel(order=1, resolution=0.35, joint=j)
        res = model.static(Materials(**design), settings[j]["pressure_pa"])
        assert rec["result"]["alpha_rad"] == res.alpha_rad
        assert rec["result"]["beta_rad"] == res.beta_rad
    assert recs["bonded"]["result"]["alpha_rad"] != recs["sliding"]["result"]["alpha_rad"]
    # a second run reads the cache: same records, no new file
    again = run_designs(
        [design], batch.evaluate_design, settings["sliding"], tmp_path, max_workers=0, progress=False
    )
    assert again[0] == recs["sliding"] and len(list(tmp_path.glob("*.json"))) == 2


def test_dynamics_refuses_another_joint():
    cal = default_calibration()
    with pytest.raises(InvalidParameter, match="bonded joint"):
        calibrate_dynamics(cal, batch.evaluate_modes, batch.fe_settings(**COARSE, joint="sliding"), "unused")


# ---- the artifact ------------------------------------------------------------------------------


def test_old_artifact_without_joint_is_bonded(tmp_path):
    d = json.loads(default_calibration().to_json())
    d.pop("joint")
    path = tmp_path / "old.json"
    path.write_text(json.dumps(d))
    cal = Calibration.load(path)
    assert cal.joint == "bonded"
    assert LumpedModel.load(path).joint == "bonded"
    with pytest.raises(InvalidParameter, match="bonded joint"):
        LumpedModel(cal, joint="sliding")
    path.write_text(json.dumps(d | {"joint": "layer"}))
    with pytest.raises(CorruptCalibration, match="joint"):
        Calibration.load(path)


def test_sliding_artifact_records_its_joint_and_fit():
    cal = sliding_calibration()
    assert cal.joint == "sliding" and cal.fe_settings["joint"] == "sliding"
    # the default calibration's sampler and domain
    assert cal.domain == DesignSpace().to_dict() == default_calibration().domain
    assert Calibration.from_dict(json.loads(cal.to_json())) == cal
    p = cal.provenance
    assert (p["samples"], p["validation_samples"], p["seed"]) == (128, 64, 0)  # the default's sizes
    assert (cal.training["n"], cal.validation["n"]) == (128, 64)
    for block in (cal.training, cal.validation):
        assert 0 < block["rms_alpha"] <= block["max_alpha"] and 0 < block["rms_beta"] <= block["max_beta"]
    # what docs/lumped.md §3.14 states: held out, α within 4 % and β within 1.5 %
    assert cal.validation["max_alpha"] < 0.04 and cal.validation["max_beta"] < 0.015
    dyn = cal.dynamics
    assert dyn["shear_factor"] > 0 and dyn["validation"]["n"] >= 2


# ---- the lumped model -------------------------------------------------------------------------


def test_lumped_model_joint_choice():
    assert LumpedModel.default().joint == "bonded"
    sl = LumpedModel.default(joint="sliding")
    assert sl.joint == "sliding" and LumpedModel(joint="sliding").calibration == sl.calibration
    assert sl.shear_factor == sliding_calibration().shear_factor
    with pytest.raises(InvalidParameter, match="bonded and sliding"):
        LumpedModel.default(joint="layer")
    with pytest.raises(InvalidParameter, match="bonded and sliding"):
        LumpedModel(joint="glued")


def _case_moduli() -> dict[str, np.ndarray]:
    return {k: np.array([getattr(c.materials(), k) for c in THESIS_CASES]) for k in MODULI}


def _lumped_cases(joint: str) -> tuple[np.ndarray, np.ndarray]:
    lm = LumpedModel.default(joint=joint)
    r = lm.static(
        [
            {
                k: getattr(c.materials(), k)
                for k in (
                    "pedicle_e_pa",
                    "gap_e_pa",
                    "capsule_e_pa",
                    "plate_e_pa",
                    "stapes_e_pa",
                    "incus_e_pa",
                )
            }
            for c in THESIS_CASES
        ]
    )
    return r.alpha_rad, r.beta_rad


def _fe_cases() -> np.ndarray:
    names = [c.name for c in THESIS_CASES]
    assert names == list(FE_CASES_URAD)
    return np.array([FE_CASES_URAD[n] for n in names]) * 1e-6  # (case, joint, α/β), rad


def test_seven_cases_against_fe():
    """Each joint's lumped model on the seven cases is within its own held-out error of FE with
    that joint (docs/model.md §2.12's table; it has 4 significant digits: 0.1 % of room)."""
    fe = _fe_cases()
    for k, joint in enumerate(("bonded", "sliding")):
        a, b = _lumped_cases(joint)
        v = LumpedModel.default(joint=joint).calibration.validation
        assert np.all(np.abs(a / fe[:, k, 0] - 1) <= v["max_alpha"] + 1e-3), (joint, a / fe[:, k, 0] - 1)
        assert np.all(np.abs(b / fe[:, k, 1] - 1) <= v["max_beta"] + 1e-3), (joint, b / fe[:, k, 1] - 1)


def _fe_joint_change() -> tuple[np.ndarray, np.ndarray]:
    """FE's α change bonded → sliding per case, and where it exceeds 0.5 % (c20, c100, j5c20)."""
    fe = _fe_cases()
    d_fe = fe[:, 1, 0] / fe[:, 0, 0] - 1
    clear = np.abs(d_fe) > 0.005
    assert clear.sum() == 3
    return d_fe, clear


def test_sliding_against_bonded_as_fe_says():
    """FE (docs/model.md §2.12): sliding moves α by −1.0 % to +1.5 %. Where it moves by more than
    0.5 % (c20 +0.9 %, c100 −1.0 %, j5c20 +1.5 %: more than either calibration's RMS α error), the
    lumped α moves the same way, the sliding calibration against the bonded one fitted alike (same
    designs, least squares). With the bonded exponent ¾ on the plate face, c100 moved the wrong way
    (+0.4 %); with the sliding face's ¼ all three are right (docs/lumped.md §3.14)."""
    from isj.lumped.model import FACTOR_NAMES, static_response

    d_fe, clear = _fe_joint_change()
    bonded = [LIKE_FOR_LIKE_BONDED.get(n, 0.0) for n in FACTOR_NAMES]
    a_bonded = static_response(bonded, **_case_moduli()).alpha_rad
    d_lumped = _lumped_cases("sliding")[0] / a_bonded - 1
    assert np.all(np.sign(d_lumped[clear]) == np.sign(d_fe[clear])), (d_fe, d_lumped)


@pytest.mark.xfail(
    strict=True,
    reason="the shipped bonded calibration (format 5, fitted near-minimax with 40 corner designs) is "
    "0.7-1.9 % low in alpha on the seven cases, more than c100's FE change (-1.0 %); docs/lumped.md 3.14",
)
def test_sliding_against_shipped_bonded_as_fe_says():
    """The same against the shipped bonded calibration (the report's lumped columns)."""
    d_fe, clear = _fe_joint_change()
    d_lumped = _lumped_cases("sliding")[0] / _lumped_cases("bonded")[0] - 1
    assert np.all(np.sign(d_lumped[clear]) == np.sign(d_fe[clear])), (d_fe, d_lumped)


def test_sliding_alpha_within_0_65_percent_on_the_seven_cases():
    """docs/lumped.md §3.14: with the sliding face's exponent the sliding calibration's α is within
    0.65 % of FE in every one of the seven cases (FE's table has 4 digits: 0.05 % of room)."""
    err = _lumped_cases("sliding")[0] / _fe_cases()[:, 1, 0] - 1
    assert np.abs(err).max() <= 0.0065 + 5e-4, err


#: α and β (rad/Pa) of the bonded equations before the exponent depended on the joint (9139807, where
#: PLATE_SUPPORT_EXPONENT was the float 0.75), for :func:`test_bonded_equations_unchanged_bit_for_bit`'s
#: factors and moduli, on the default geometry and on a thinner plate over a thicker gap.
BONDED_BEFORE = {
    "default": (
        [2.806910823305579e-08, 2.010255817068342e-08, 1.6538894903837593e-08, 3.249176924239128e-08],
        [8.935874476480009e-08, 1.6381794196284246e-06, 8.464661668677011e-07, 3.1845534022913384e-07],
    ),
    "thin_plate": (
        [2.9347704472596568e-08, 2.1152047970310597e-08, 1.792500337751571e-08, 3.6756817704164556e-08],
        [9.905148719772732e-08, 1.6992582445010891e-06, 9.199322010782038e-07, 3.513921312705671e-07],
    ),
}


def test_bonded_equations_unchanged_bit_for_bit():
    """The bonded equations give the bits they gave before the joint entered them (default joint and
    joint="bonded"); the sliding ones differ from them by the plate face's term alone, evaluated here
    on its own with s = f_s support (10³ E_gap/E_plate)^n, n = ¾ and ¼; β does not see the joint."""
    from isj.lumped.model import FACTOR_NAMES, PLATE_SUPPORT_EXPONENT, Lever, equations, moduli_arrays

    from isj.design import Geometry

    assert PLATE_SUPPORT_EXPONENT == {"bonded": 0.75, "sliding": 0.25}
    f = np.array([LIKE_FOR_LIKE_BONDED.get(n, 0.0) for n in FACTOR_NAMES])
    f[FACTOR_NAMES.index("pedicle_face")], f[FACTOR_NAMES.index("root_plate")] = 0.3, 1.3
    E = moduli_arrays(
        gap_e_pa=np.array([1e6, 4.3e7, 5e7, 2e7]),
        plate_e_pa=np.array([5e9, 4e8, 3e8, 1e9]),
        capsule_e_pa=np.array([3e8, 1.2e7, 1e7, 1e8]),
        pedicle_e_pa=np.array([2.7e10, 1e9, 5e9, 1e10]),
    )
    geometries = {
        "default": Geometry(),
        "thin_plate": Geometry().replace(plate_thickness_m=5e-5, gap_thickness_m=4e-5),
    }
    for name, g in geometries.items():
        lv = Lever.from_geometry(g)
        a, b = equations(E, f, lv)
        assert (a.tolist(), b.tolist()) == BONDED_BEFORE[name]
        ab, bb = equations(E, f, lv, "bonded")
        np.testing.assert_array_equal(ab, a)
        np.testing.assert_array_equal(bb, b)
        a_s, b_s = equations(E, f, lv, "sliding")
        np.testing.assert_array_equal(b_s, b)
        r = 1e3 * E["gap_e_pa"] / E["plate_e_pa"]
        face = {}
        for n in (0.75, 0.25):
            s = f[FACTOR_NAMES.index("plate_support")] * lv.support * r**n
            face[n] = np.exp(-s) * np.cos(s)
        scale = lv.force_per_pa * lv.joint_arm * lv.bulk * lv.plate_face * f[FACTOR_NAMES.index("plate_bulk")]
        np.testing.assert_allclose(a_s - a, scale * (face[0.25] - face[0.75]) / E["plate_e_pa"], rtol=1e-9)
        assert np.all(a_s != a)
    with pytest.raises(InvalidParameter, match="joint = 'layer'"):
        equations(E, f, Lever.from_geometry(Geometry()), "layer")


def test_sliding_chain_drops_the_gap_shear():
    """The chain's joint shear spring: bonded, the gap's and the capsule's walls; sliding, the
    capsule's alone (the gap's face glides). Every other spring is the same."""
    from isj.lumped.dynamics import chain_stiffness

    from isj.design import Geometry

    g, f = Geometry(), sliding_calibration().factor_array()
    e_gap, e_cap, nu = np.array([2e6, 1e7, 4e7]), np.array([3e7, 1e8, 2e8]), 0.3
    st = {
        j: chain_stiffness(f, 0.9, g, joint=j, gap_e_pa=e_gap, capsule_e_pa=e_cap)
        for j in ("bonded", "sliding")
    }
    gap = 0.9 / (2 * (1 + nu)) * e_gap * g.joint_x_m * g.joint_y_m / g.gap_thickness_m
    cap = 0.9 / (2 * (1 + nu)) * e_cap * 2 * (g.joint_x_m + 2 * g.capsule_thickness_m) * g.capsule_thickness_m
    cap /= g.gap_thickness_m + 2 * g.capsule_reach_m
    np.testing.assert_allclose(st["sliding"].k_shear, cap, rtol=1e-13)
    np.testing.assert_allclose(st["bonded"].k_shear, gap + cap, rtol=1e-13)
    # the joint's rotational spring follows each joint's static α (the plate face's exponent)
    from isj.lumped.model import static_response

    a = {j: static_response(f, g, joint=j, gap_e_pa=e_gap, capsule_e_pa=e_cap).alpha_rad for j in st}
    np.testing.assert_allclose(
        st["bonded"].k_joint / st["sliding"].k_joint, a["sliding"] / a["bonded"], rtol=1e-13
    )
    for name in ("c_root", "c_top", "beam"):
        np.testing.assert_array_equal(getattr(st["bonded"], name), getattr(st["sliding"], name))
    with pytest.raises(InvalidParameter, match="joint"):
        chain_stiffness(f, joint="layer")
    # LumpedModel threads its joint into the chain: the sliding chain is softer in shear, so its
    # second natural frequency is lower than the same factors' bonded chain
    sl = LumpedModel.default(joint="sliding")
    from isj.lumped.dynamics import chain_model

    f_sl = sl.natural_frequencies_hz()
    f_bo = chain_model(sl.factors, sl.shear_factor, rayleigh_b_s=0.0, joint="bonded").poles()[0]
    np.testing.assert_array_equal(
        f_sl, chain_model(sl.factors, sl.shear_factor, rayleigh_b_s=0.0, joint="sliding").poles()[0]
    )
    assert f_sl[1] < 0.8 * f_bo[1]


def test_lumped_ear_takes_the_calibrations_joint():
    """LumpedModel.ear passes its joint on: the ear's condensed joint is the sliding equations' coupling,
    not the bonded form's with the same factors (the exponent of the plate face differs)."""
    from isj.lumped.dynamics import joint_coupling

    sl = LumpedModel.default(joint="sliding")
    k_ear = sl.ear().joint[0]
    k = {j: joint_coupling(sl.factors, sl.geometry, joint=j).stiffness[0] for j in ("bonded", "sliding")}
    np.testing.assert_array_equal(k_ear, k["sliding"])
    assert not np.allclose(k["sliding"], k["bonded"], rtol=1e-6)


# ---- the command line --------------------------------------------------------------------------


def test_cli_joint(run_cli):
    out = {}
    for joint in ("bonded", "sliding"):
        code, stdout, _ = run_cli("lumped", "solve", "--joint", joint, "--json")
        assert code == 0
        out[joint] = json.loads(stdout)
        assert out[joint]["joint"] == joint
        r = LumpedModel.default(joint=joint).static()
        assert out[joint]["alpha_rad"] == float(r.alpha_rad) and out[joint]["beta_rad"] == float(r.beta_rad)
    assert out["sliding"]["calibration"] == "sliding"
    assert out["sliding"]["validation"] == sliding_calibration().validation
    code, _, err = run_cli("lumped", "solve", "--joint", "layer")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "--joint = layer" in err and "bonded, sliding" in err
    code, _, err = run_cli("calibrate", "--joint", "layer", "--out", "x.json")
    assert code == 2 and "--joint = layer" in err


def test_cli_joint_against_calibration_file(run_cli, tmp_path):
    path = tmp_path / "sliding.json"
    path.write_text(sliding_calibration().to_json())
    code, stdout, _ = run_cli("lumped", "solve", "--calibration", str(path), "--json")
    assert code == 0 and json.loads(stdout)["joint"] == "sliding"
    code, _, err = run_cli("lumped", "solve", "--calibration", str(path), "--joint", "bonded")
    assert code == 2 and "sliding joint" in err and len(err.strip().splitlines()) == 1


# ---- the held-out claim, recomputed with FE ---------------------------------------------------


@pytest.mark.slow
def test_held_out_errors_as_claimed(tmp_path):
    """Three of the artifact's held-out designs (Latin hypercube, seed + 1), FE at the artifact's
    mesh: the lumped errors lie within the artifact's held-out maxima."""
    cal = sliding_calibration()
    fs = cal.fe_settings
    settings = batch.fe_settings(order=fs["order"], resolution=fs["resolution"], joint="sliding")
    held = sample(
        DesignSpace.from_dict(cal.domain),
        cal.provenance["validation_samples"],
        cal.provenance["seed"] + 1,
        method="lhs",
    )[:3]
    recs = run_designs(held, batch.evaluate_design, settings, tmp_path, max_workers=0, progress=False)
    e = error_stats(cal.factor_array(), records_for_fit(recs), joint="sliding")
    assert e["max_alpha"] <= cal.validation["max_alpha"] + 1e-9
    assert e["max_beta"] <= cal.validation["max_beta"] + 1e-9
    # and they are not all trivially zero: the lumped model is an approximation
    assert e["max_alpha"] > 1e-5 and e["max_beta"] > 1e-5


# ---- the report's sliding page ----------------------------------------------------------------


@pytest.mark.slow
def test_report_sliding_page_shows_lumped_beside_fe(tmp_path):
    """The sliding step's lumped columns are each joint's LumpedModel on the seven cases; the page's
    table prints them; the layer has none; the step's cache key sees each joint's calibration."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from isj.reports.config import load_config
    from isj.reports.csvdata import tables
    from isj.reports.layout import urad
    from isj.reports.sliding import sliding_page, sliding_step
    from isj.reports.steps import Context, step_inputs

    cfg = load_config(
        overrides=["mesh.order=1", "mesh.resolution=0.35", 'sliding.joints=["bonded","sliding","layer"]']
    )
    ctx = Context(config=cfg, calibration=default_calibration(), fe_cache_dir=tmp_path, progress=False)
    res, _ = sliding_step(ctx)
    rows = {(r["case"], r["joint"]): r for r in res["rows"]}
    for joint in ("bonded", "sliding"):
        a, b = _lumped_cases(joint)
        for i, case in enumerate(THESIS_CASES):
            r = rows[case.name, joint]
            assert (r["lumped_alpha_rad"], r["lumped_beta_rad"]) == (float(a[i]), float(b[i]))
            assert r["lumped_beta_over_alpha"] == pytest.approx(b[i] / a[i], rel=1e-14)
    assert all(rows[c.name, "layer"]["lumped_alpha_rad"] is None for c in THESIS_CASES)
    fig = plt.figure(figsize=(8.27, 11.69))
    sliding_page(fig, res)
    text = "\n".join(t.get_text() for t in fig.texts)
    plt.close(fig)
    assert urad(rows["c100", "sliding"]["lumped_alpha_rad"]) in text and "lumped alpha" in text
    csv = tables("sliding", res, {})["sliding.csv"]
    assert "lumped_alpha_rad" in csv.splitlines()[1] and len(csv.splitlines()) == 2 + 21
    # a refitted sliding calibration (data, not code) changes the step's cache key
    key = step_inputs(ctx, ("design", "geometry", "mesh", "sliding"))
    assert key["joint_calibrations"]["sliding"]["factors"] == sliding_calibration().factors


@pytest.mark.slow
def test_held_out_frequencies_as_claimed(tmp_path):
    """Two of the chain's held-out modal designs (Latin hypercube, seed 101), FE modes with the
    sliding joint at the artifact's mesh: the chain's f1 and f2 within the artifact's held-out maxima."""
    from isj.calibration.pipeline import frequency_errors

    cal = sliding_calibration()
    fs = cal.fe_settings
    settings = dict(
        batch.fe_settings(order=fs["order"], resolution=fs["resolution"], joint="sliding"),
        kind="modes",
        n_modes=6,
    )
    held = sample(DesignSpace.from_dict(cal.domain), 8, cal.provenance["seed"] + 101, method="lhs")[:2]
    recs = run_designs(held, batch.evaluate_modes, settings, tmp_path, max_workers=0, progress=False)
    fe = np.array([r["result"]["in_plane_freq_hz"][:2] for r in recs])
    e = frequency_errors(cal.factor_array(), cal.shear_factor, held, fe, joint="sliding")
    v = cal.dynamics["validation"]
    assert e["max_f1"] <= v["max_f1"] + 1e-9 and e["max_f2"] <= v["max_f2"] + 1e-9
    # the bonded chain's shear spring (gap and capsule) is far off with the sliding joint
    assert frequency_errors(cal.factor_array(), cal.shear_factor, held, fe, joint="bonded")["max_f2"] > 0.2
