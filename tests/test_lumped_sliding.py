"""The lumped model's sliding joint (docs/lumped.md §3.14): FE settings and cache keys carry the joint,
the shipped sliding calibration, ``LumpedModel(joint=...)`` and ``isj lumped solve --joint``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from isj.calibration.doe import DesignSpace, sample
from isj.calibration.pipeline import calibrate_dynamics, error_stats, records_for_fit, settings_joint
from isj.calibration.runner import design_key, run_designs
from isj.fem import batch
from isj.lumped.api import LumpedModel
from isj.lumped.artifact import Calibration, CorruptCalibration, default_calibration, sliding_calibration

from isj.cases import THESIS_CASES
from isj.design import InvalidParameter, Materials

#: FE α and β (µrad) of the seven thesis cases, bonded and sliding, at the default pressure, P2 on
#: the default mesh (resolution 1): the table of docs/model.md §2.12 (isj.fem.sliding.compare_cases).
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
    recs = {j: run_designs([design], batch.evaluate_design, s, tmp_path, max_workers=0, progress=False)[0]
            for j, s in settings.items()}  # fmt: skip
    assert recs["bonded"]["key"] != recs["sliding"]["key"]
    assert len(list(tmp_path.glob("*.json"))) == 2
    # each record is its joint's FE model, bit for bit (the joint reached the model)
    for j, rec in recs.items():
        model = PedicleJointModel(order=1, resolution=0.35, joint=j)
        res = model.solve(Materials(**design), settings[j]["pressure_pa"])
        assert rec["result"]["alpha_rad"] == res.alpha_rad
        assert rec["result"]["beta_rad"] == res.beta_rad
    assert recs["bonded"]["result"]["alpha_rad"] != recs["sliding"]["result"]["alpha_rad"]
    # a second run reads the cache: same records, no new file
    again = run_designs([design], batch.evaluate_design, settings["sliding"], tmp_path, max_workers=0,
                        progress=False)  # fmt: skip
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


def _lumped_cases(joint: str) -> tuple[np.ndarray, np.ndarray]:
    lm = LumpedModel.default(joint=joint)
    r = lm.static([{k: getattr(c.materials(), k) for k in ("pedicle_e_pa", "gap_e_pa", "capsule_e_pa",
                                                           "plate_e_pa", "stapes_e_pa", "incus_e_pa")}
                   for c in THESIS_CASES])  # fmt: skip
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


@pytest.mark.xfail(
    strict=True,
    reason="c100: FE's α falls 1.0 % with sliding, the lumped α rises; the plate face's "
    "foundation exponent is the bonded joint's 3/4 (docs/lumped.md 3.14: 1/4 gets all three right)",
)
def test_sliding_against_bonded_as_fe_says():
    """FE (docs/model.md §2.12): sliding moves α by −1.0 % to +1.5 %. Where it moves by more than
    0.5 % (c20 +0.9 %, c100 −1.0 %, j5c20 +1.5 %: more than either calibration's RMS α error), the
    lumped α moves the same way."""
    fe = _fe_cases()
    d_fe = fe[:, 1, 0] / fe[:, 0, 0] - 1
    d_lumped = _lumped_cases("sliding")[0] / _lumped_cases("bonded")[0] - 1
    clear = np.abs(d_fe) > 0.005
    assert clear.sum() == 3
    assert np.all(np.sign(d_lumped[clear]) == np.sign(d_fe[clear])), (d_fe, d_lumped)


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
    np.testing.assert_array_equal(st["bonded"].k_joint, st["sliding"].k_joint)
    with pytest.raises(InvalidParameter, match="joint"):
        chain_stiffness(f, joint="layer")
    # LumpedModel threads its joint into the chain: the sliding chain is softer in shear, so its
    # second natural frequency is lower than the same factors' bonded chain
    sl = LumpedModel.default(joint="sliding")
    from isj.lumped.dynamics import chain_model

    f_sl = sl.natural_frequencies_hz()
    f_bo = chain_model(sl.factors, sl.shear_factor, rayleigh_b_s=0.0, joint="bonded").poles()[0]
    np.testing.assert_array_equal(f_sl, chain_model(sl.factors, sl.shear_factor, rayleigh_b_s=0.0,
                                                    joint="sliding").poles()[0])  # fmt: skip
    assert f_sl[1] < 0.8 * f_bo[1]


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
    held = sample(DesignSpace.from_dict(cal.domain), cal.provenance["validation_samples"],
                  cal.provenance["seed"] + 1, method="lhs")[:3]  # fmt: skip
    recs = run_designs(held, batch.evaluate_design, settings, tmp_path, max_workers=0, progress=False)
    e = error_stats(cal.factor_array(), records_for_fit(recs))
    assert e["max_alpha"] <= cal.validation["max_alpha"] + 1e-9
    assert e["max_beta"] <= cal.validation["max_beta"] + 1e-9
    # and they are not all trivially zero: the lumped model is an approximation
    assert e["max_alpha"] > 1e-5 and e["max_beta"] > 1e-5


# ---- the report's sliding page ----------------------------------------------------------------


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
    settings = dict(batch.fe_settings(order=fs["order"], resolution=fs["resolution"], joint="sliding"),
                    kind="modes", n_modes=6)  # fmt: skip
    held = sample(DesignSpace.from_dict(cal.domain), 8, cal.provenance["seed"] + 101, method="lhs")[:2]
    recs = run_designs(held, batch.evaluate_modes, settings, tmp_path, max_workers=0, progress=False)
    fe = np.array([r["result"]["in_plane_freq_hz"][:2] for r in recs])
    e = frequency_errors(cal.factor_array(), cal.shear_factor, held, fe, joint="sliding")
    v = cal.dynamics["validation"]
    assert e["max_f1"] <= v["max_f1"] + 1e-9 and e["max_f2"] <= v["max_f2"] + 1e-9
    # the bonded chain's shear spring (gap and capsule) is far off with the sliding joint
    assert frequency_errors(cal.factor_array(), cal.shear_factor, held, fe, joint="bonded")["max_f2"] > 0.2
