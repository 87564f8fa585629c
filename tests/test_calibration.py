"""Calibration pipeline end to end: the fit on real (coarse) FE results, the artifact, the guard."""

import json

import casadi  # noqa: F401 - a hard dependency: without it these tests fail, they do not skip
import gmsh  # noqa: F401 - a hard dependency: without it these tests fail, they do not skip
import numpy as np
import pytest
from isj.calibration.pipeline import calibrate
from isj.fem.batch import evaluate_design, fe_settings
from isj.lumped.artifact import Calibration, default_calibration

from isj.cli import main
from isj.design_space import DesignSpace
from isj.errors import CorruptCalibration

pytestmark = pytest.mark.slow  # FE designs for a calibration (module fixture)

COARSE_FE = {"order": 2, "resolution": 0.5}
# pedicle, gap and capsule moduli vary; plate and stapes stay at their defaults
JOINT_SPACE = DesignSpace(plate_e_pa=(1e9, 1e9), stapes_e_pa=(1e9, 1e9))


@pytest.fixture(scope="module")
def small_calibration(tmp_path_factory):
    cache = tmp_path_factory.mktemp("fe")
    cal = calibrate(
        evaluate_design,
        fe_settings(**COARSE_FE),
        cache,
        samples=16,
        validation=8,
        seed=1,
        space=JOINT_SPACE,
        progress=False,
    )
    return cal, cache


def test_calibrated_model_meets_tolerance_on_held_out_fe_points(small_calibration):
    cal, _ = small_calibration
    assert cal.validation["n"] == 8
    assert cal.validation["max_alpha"] < 0.03 and cal.validation["max_beta"] < 0.03
    assert cal.factors["pedicle_bending"] == pytest.approx(1.0, abs=0.1)  # the beam is a beam


def test_artifact_round_trip_and_provenance(small_calibration, tmp_path):
    cal, _ = small_calibration
    path = tmp_path / "cal.json"
    path.write_text(cal.to_json())
    back = Calibration.load(path)
    assert back.factors == cal.factors and back.domain == cal.domain
    d = json.loads(path.read_text())
    assert d["fe_settings"]["order"] == 2 and d["fe_settings"]["mesh_hash"]
    assert "casadi" in d["provenance"]["versions"] and d["provenance"]["seed"] == 1


@pytest.mark.parametrize(
    "text", ["{not json", '{"format": 1}', '{"format": 1, "factors": {}, "domain": {}}', "[]"]
)
def test_corrupt_calibration_is_a_clear_error(tmp_path, capsys, text):
    bad = tmp_path / "bad.json"
    bad.write_text(text)
    with pytest.raises(CorruptCalibration):
        Calibration.load(bad)
    assert main(["lumped", "solve", "--calibration", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "calibration" in err and len(err.strip().splitlines()) == 1


def test_format_2_file_loads_as_the_model_without_load_sharing():
    """A format-2 file predates the load_sharing term; 0 makes the equations those of format 2."""
    d = json.loads(default_calibration().to_json())
    d["format"] = 2
    del d["factors"]["load_sharing"]
    old = Calibration.from_dict(d)
    assert old.factors["load_sharing"] == 0.0
    d["format"] = 3
    with pytest.raises(CorruptCalibration, match="load_sharing"):
        Calibration.from_dict(d)
    d["format"] = 7
    with pytest.raises(CorruptCalibration, match="expected one of 2, 3, 4, 5, 6"):
        Calibration.from_dict(d)


def test_shipped_calibration_loads_and_records_its_validation():
    cal = default_calibration()
    assert cal.validation["n"] >= 50
    assert set(cal.domain) >= {"pedicle_e_pa", "gap_e_pa", "capsule_e_pa"}


def test_lumped_solve_warns_outside_domain(capsys):
    assert main(["lumped", "solve", "--json", "--gap-e", "500e6"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["alpha_rad"] > 0
    assert "gap_e_pa outside the calibrated domain" in err


def test_explore_spot_checks_guard(small_calibration, tmp_path, capsys):
    cal, cache = small_calibration
    path = tmp_path / "cal.json"
    path.write_text(cal.to_json())
    base = [
        "explore",
        "--calibration",
        str(path),
        "--cache",
        str(cache),
        "--order",
        "2",
        "--resolution",
        "0.5",
        "--pedicle-e",
        "2e9:20e9",
        "--gap-e",
        "3e6:30e6",
        "--n",
        "4",
        "--spot-checks",
        "2",
        "--no-guard",  # the FE spot checks alone (the surrogate's guard: tests/test_explore_guard.py)
        "--json",
    ]
    assert main(base + ["--tolerance", "0.05"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_designs"] == 16 and len(summary["spot_checks"]) == 2 and summary["passed"]
    assert main(base + ["--tolerance", "1e-6"]) == 1  # a tolerance no model meets: non-zero exit
    capsys.readouterr()


def test_lumped_is_fast():
    """Vectorised evaluation: a million designs is a handful of numpy operations (no timing asserted)."""
    from isj.lumped.model import static_response

    E = np.geomspace(1e9, 2e10, 1_000_000)
    r = static_response(default_calibration().factor_array(), pedicle_e_pa=E)
    assert r.beta_rad.shape == (1_000_000,) and np.all(np.diff(r.beta_rad) < 0)
