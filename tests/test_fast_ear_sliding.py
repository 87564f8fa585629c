"""The fast ear of the sliding joint (docs/fast_ear.md §14.7) against the FE ear it reduces.

The report's transmission step takes its sliding case from the sliding joint's own fast ear. The
sliding joint ties the gap's face to the plate in the normal direction only (docs/model.md §2.12):
its matrices are still affine in the regions' moduli, so the same reduction applies. Checked here on
a coarse joint (P2, resolution 0.35) in a coarse drum (0.25 mm) against the reduced FE ear of each
design (:func:`fem.ear.reduced_ear.reduced_ear`, itself checked against direct harmonic solves in
tests/test_ear_reduced.py) and the rigid-joint FE ear.
"""

import numpy as np
import pytest
from isj.fem.ear.fast_ear import DEFAULT_POD_TOL, build_fast_ear, cache_key, cache_key_of, stored_fast_ear
from isj.fem.ear.middle_ear import MiddleEarModel
from isj.fem.ear.reduced_ear import reduced_ear
from isj.fem.model import PedicleJointModel

from isj.cases import case_by_name
from isj.design import Materials

pytestmark = pytest.mark.slow

#: The targets to 10 kHz (issue 24): H_V (dB, degrees), ΔH_V (dB, degrees).
HV_DB, HV_DEG, DHV_DB, DHV_DEG = 0.5, 3.0, 0.1, 1.0
FREQ_HZ = np.geomspace(100.0, 20e3, 30)
LOW = FREQ_HZ <= 10e3
DRUM_M = 0.25e-3


def _db_deg(r):
    return np.abs(20 * np.log10(np.abs(r))), np.abs(np.degrees(np.angle(r)))


@pytest.fixture(scope="module")
def ear():
    joint = PedicleJointModel(order=2, resolution=0.35, joint="sliding")
    return MiddleEarModel(joint=joint, drum_mesh_size_m=DRUM_M)


@pytest.fixture(scope="module")
def fast(ear):
    return build_fast_ear(ear)


def test_the_sliding_ear_has_its_own_key(ear):
    bonded = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=0.35), drum_mesh_size_m=DRUM_M)
    assert cache_key_of(ear) != cache_key_of(bonded)
    # keyed through the bonded ear with the sliding joint in its place (what the report does to
    # find the shipped sliding fast ear without building the sliding ear): the sliding ear's key
    settings = {"fmax_hz": 20e3, "pod_tol": DEFAULT_POD_TOL}
    assert cache_key(bonded, None, None, settings, joint=ear.joint) == cache_key_of(ear)


def test_a_fast_ear_neither_cached_nor_shipped_is_not_built(ear, tmp_path, monkeypatch):
    monkeypatch.setenv("ISJ_FE_CACHE_DIR", str(tmp_path))
    assert stored_fast_ear(ear) is None
    assert not any(tmp_path.rglob("*.npz"))


@pytest.mark.parametrize("name", ["base", "j5c20"])
def test_sliding_fast_ear_within_the_targets(ear, fast, name):
    mats = case_by_name(name).materials(Materials())
    fe = reduced_ear(ear, mats, fmax_hz=20e3).frequency_response(FREQ_HZ)["stapes_velocity_m_s"]
    rigid = reduced_ear(ear.rigid_connection(), fmax_hz=20e3).frequency_response(FREQ_HZ)
    out = fast.batch(FREQ_HZ, mats)
    db, deg = _db_deg(out["h_v"][0] / fe)
    assert db[LOW].max() <= HV_DB and deg[LOW].max() <= HV_DEG, (db.max(), deg.max())
    db, deg = _db_deg((out["h_v"][0] / out["h_v_rigid"]) / (fe / rigid["stapes_velocity_m_s"]))
    assert db[LOW].max() <= DHV_DB and deg[LOW].max() <= DHV_DEG, (db.max(), deg.max())
    # the sliding joint is not the bonded one: its H_V differs from the bonded fast ear's by more
    # than the error allowed above, so the check can tell the two apart
    bonded = MiddleEarModel(joint=PedicleJointModel(order=2, resolution=0.35), drum_mesh_size_m=DRUM_M)
    fe_bonded = reduced_ear(bonded, mats, fmax_hz=20e3).frequency_response(FREQ_HZ)["stapes_velocity_m_s"]
    db, _ = _db_deg(fe_bonded / fe)
    assert db.max() > DHV_DB, db.max()
