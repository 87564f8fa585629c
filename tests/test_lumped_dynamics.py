"""Lumped dynamics: the second-order model against exact solutions, its static limit, and FE."""

import numpy as np
import pytest

from lumped.artifact import default_calibration
from lumped.dynamics import SecondOrderModel, chain_model, frequency_response
from lumped.model import static_response


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


def test_static_limit_is_the_calibrated_static_model():
    f = default_calibration().factor_array()
    moduli = {"pedicle_e_pa": np.array([3e9, 12e9]), "gap_e_pa": np.array([5e6, 20e6])}
    dyn = frequency_response(chain_model(f, **moduli), [0.0], pressure_pa=28.5)
    st = static_response(f, pressure_pa=28.5, **moduli)
    assert np.allclose(dyn[:, 0, 0].real, st.alpha_rad, rtol=1e-12)
    assert np.allclose(dyn[:, 0, 1].real, st.beta_rad, rtol=1e-12)
    assert np.allclose(dyn[:, 0, :2].imag, 0)


def test_many_designs_at_once_equal_one_at_a_time():
    f = default_calibration().factor_array()
    E = np.geomspace(2e9, 20e9, 7)
    many = chain_model(f, pedicle_e_pa=E).freq_resp(np.geomspace(100, 2e4, 11))
    assert many.shape == (7, 11, 3, 1)
    one = chain_model(f, pedicle_e_pa=E[4]).freq_resp(np.geomspace(100, 2e4, 11))
    assert np.allclose(many[4], one, rtol=1e-13)


def test_low_frequency_roll_off_matches_fe(coarse_model):
    """α(1 kHz)/α(0) from FE harmonic solves and from the lumped model (Rayleigh b = 1e-4 s)."""
    from fem.dynamics import harmonic

    u = harmonic(coarse_model, [0.0, 1000.0], pressure_pa=1.0)
    fe = coarse_model.angles[:2] @ u.T  # rows α, β; columns frequencies
    lum = frequency_response(chain_model(default_calibration().factor_array()), [0.0, 1000.0], 1.0)
    for i in range(2):
        ratio_fe = fe[i, 1] / fe[i, 0]
        ratio_lum = lum[1, i] / lum[0, i]
        assert abs(ratio_lum / ratio_fe - 1) < 0.01  # magnitude and phase together
