"""ΔH_V = H_V / H_V,rigid wherever isj writes it: the lumped ear sweep, the fast ear's coverage.

The references are other code paths: the rigid connection's own sweep of the same lumped ear,
and the definitions of :func:`isj.responses.delta_columns`.
"""

import numpy as np
import pytest
from isj.lumped.artifact import default_calibration

from isj.damping import resolve
from isj.design import Materials
from isj.ear import EarMaterials
from isj.errors import InvalidParameter
from isj.responses import DELTA_COLUMNS, delta_columns
from isj.studies.ear_workflow import lumped_delta
from isj.studies.sweeps import ear_sweep

FREQ_HZ = np.geomspace(100.0, 5000.0, 41)


def _stapes_velocity(sw) -> np.ndarray:
    return 2j * np.pi * sw.freq_hz * sw.response[:, sw.outputs.index("stapes_m")]


@pytest.fixture(scope="module")
def sweeps():
    cal, mats, ear = default_calibration(), Materials(gap_e_pa=3e6), EarMaterials()
    damping = resolve(None)
    kw = {"damping": damping, "drum_modes": 20}
    joint = ear_sweep(cal, FREQ_HZ, mats, ear, **kw)
    rigid = ear_sweep(cal, FREQ_HZ, mats, ear, rigid_joint=True, **kw)
    return cal, mats, ear, damping, joint, rigid


def test_lumped_delta_is_h_v_over_the_rigid_sweep(sweeps):
    cal, mats, ear, damping, joint, rigid = sweeps
    d = lumped_delta(joint, cal, mats, ear, damping, 20, rigid_joint=False)
    assert set(d["columns"]) == set(DELTA_COLUMNS)
    hv, hr = _stapes_velocity(joint), _stapes_velocity(rigid)
    # H_V (dB) minus ΔH_V (dB) is the rigid connection's H_V, from its own sweep
    np.testing.assert_allclose(
        d["columns"]["h_v_db"] - d["columns"]["delta_h_v_db"], 20 * np.log10(abs(hr)), atol=1e-9
    )
    np.testing.assert_allclose(d["columns"]["h_v_db"], 20 * np.log10(abs(hv)), rtol=0, atol=1e-12)
    # a softer gap than the rigid connection: the lumped joint is more compliant, so ΔH_V ≠ 0
    assert np.abs(d["columns"]["delta_h_v_db"]).max() > 1e-4


def test_lumped_delta_of_the_rigid_connection_is_one(sweeps):
    cal, mats, ear, damping, _, rigid = sweeps
    d = lumped_delta(rigid, cal, mats, ear, damping, 20, rigid_joint=True)
    # z / z is 1 to the last bit of a complex division
    assert np.abs(d["columns"]["delta_h_v_db"]).max() < 1e-12
    assert np.abs(d["columns"]["delta_h_v_deg"]).max() < 1e-12
    assert d["summary"]["max_abs_delta_h_v_db_to_10khz"] < 1e-12


def test_delta_columns_quotes_and_worst():
    f = np.geomspace(100.0, 20e3, 101)
    hr = 1e-4 / (1 + 1j * f / 3e3)
    d = 10 ** (-np.log10(f / 100) / 20) * np.exp(1j * np.radians(-f / 1e3))  # −1 dB a decade, −1° a kHz
    out = delta_columns(f, hr * d, hr)
    q = out["summary"]["delta_h_v_at_hz"]
    assert q["1000"]["db"] == pytest.approx(-1.0, abs=1e-9)
    assert q["5000"]["deg"] == pytest.approx(-5.0, abs=1e-2)  # interpolated in log f
    assert out["summary"]["max_abs_delta_h_v_db_to_10khz"] == pytest.approx(2.0, abs=0.05)
    with pytest.raises(InvalidParameter, match="h_v, h_v_rigid"):
        delta_columns(f, hr[:-1], hr)
