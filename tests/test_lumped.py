"""Lumped model: beam limit by hand, vectorisation, one set of equations for numpy and CasADi."""

import casadi as ca
import numpy as np
import pytest
from isj.lumped.model import FACTOR_NAMES, MODULI, Lever, equations, moduli_arrays, static_response

from isj.design import Geometry
from isj.errors import InvalidParameter

ONES = np.ones(len(FACTOR_NAMES))


def test_beam_limit_by_hand():
    """With rigid plate and incus, β is Euler–Bernoulli's rotation across the pedicle."""
    g = Geometry()
    huge = 1e30
    r = static_response(
        ONES,
        g,
        pressure_pa=30.0,
        pedicle_e_pa=5e9,
        plate_e_pa=huge,
        incus_e_pa=huge,
        gap_e_pa=10e6,
        stapes_e_pa=1e9,
    )
    force = 30.0 * 250e-6 * 200e-6  # N on the incus's -x face
    arm = (455e-6 + 100e-6) - (215e-6 + 455e-6) / 2  # load centroid to pedicle mid-length (m)
    inertia = 160e-6 * 55e-6**3 / 12
    assert float(r.beta_rad) == pytest.approx(force * 240e-6 * arm / (5e9 * inertia), rel=1e-12)


def test_vectorised_over_designs_matches_one_by_one():
    rng = np.random.default_rng(0)
    E = {k: 10 ** rng.uniform(6, 10, size=50) for k in MODULI}
    many = static_response(ONES, **E)
    for i in (0, 17, 49):
        one = static_response(ONES, **{k: v[i] for k, v in E.items()})
        assert float(one.alpha_rad) == pytest.approx(many.alpha_rad[i], rel=1e-14)
        assert float(one.beta_rad) == pytest.approx(many.beta_rad[i], rel=1e-14)
    assert many.alpha_rad.shape == (50,)


def test_physical_trends():
    E = np.geomspace(1e6, 1e8, 5)
    assert np.all(np.diff(static_response(ONES, gap_e_pa=E).alpha_rad) < 0)
    assert np.all(np.diff(static_response(ONES, capsule_e_pa=E).alpha_rad) < 0)
    assert np.all(np.diff(static_response(ONES, pedicle_e_pa=E * 100).beta_rad) < 0)
    r = static_response(ONES, pressure_pa=2.0)
    assert float(r.alpha_rad) == pytest.approx(2 * float(static_response(ONES, pressure_pa=1.0).alpha_rad))


def test_casadi_expression_is_the_same_model():
    lever = Lever.from_geometry(Geometry())
    f = ca.SX.sym("f", len(FACTOR_NAMES))
    E = moduli_arrays(pedicle_e_pa=np.array([2e9, 7e9]), gap_e_pa=np.array([3e6, 30e6]))
    Edm = {k: ca.DM(np.broadcast_to(v, (2,))) for k, v in E.items()}
    a, b = equations(Edm, [f[i] for i in range(len(FACTOR_NAMES))], lever)
    fun = ca.Function("lumped", [f], [a, b])
    x = np.linspace(0.5, 2.0, len(FACTOR_NAMES))
    a_ca, b_ca = (np.asarray(v).ravel() for v in fun(x))
    a_np, b_np = equations(E, x, lever)
    assert np.allclose(a_ca, a_np, rtol=1e-14) and np.allclose(b_ca, b_np, rtol=1e-14)


@pytest.mark.parametrize("bad", [0.0, -1e9, float("nan")])
def test_impossible_moduli_are_refused(bad):
    with pytest.raises(InvalidParameter, match="pedicle_e_pa"):
        static_response(ONES, pedicle_e_pa=np.array([5e9, bad]))


def test_load_sharing_term_peaks_where_gap_and_capsule_share_the_moment():
    """The sharing compliance ∝ k_gap k_cap / (k_gap + k_cap)²: zero if one path carries all, max at equal."""
    lever = Lever.from_geometry(Geometry())
    share = FACTOR_NAMES.index("load_sharing")
    with_term, without = ONES.copy(), ONES.copy()
    without[share] = 0.0
    E = moduli_arrays(capsule_e_pa=np.geomspace(1e5, 1e11, 601))
    extra = equations(E, with_term, lever)[0] - equations(E, without, lever)[0]
    k_gap = lever.gap * E["gap_e_pa"]
    k_cap = 1 / (
        1 / (lever.capsule * E["capsule_e_pa"])
        + 1 / (lever.attachment * E["plate_e_pa"] ** 0.75 * E["capsule_e_pa"] ** 0.25)
        + 1 / (lever.attachment * E["stapes_e_pa"])
    )
    peak = np.argmax(extra)
    assert k_cap[peak] / k_gap == pytest.approx(1.0, rel=0.05)
    # the peak: a quarter of the plate face's unit compliance, times the arm and the load
    assert extra[peak] == pytest.approx(
        lever.force_per_pa * lever.joint_arm * lever.bulk / E["plate_e_pa"] / 4, rel=1e-4
    )
    unit = lever.force_per_pa * lever.joint_arm * lever.bulk / E["plate_e_pa"]
    assert np.allclose(extra, unit * k_gap * k_cap / (k_gap + k_cap) ** 2, rtol=1e-9, atol=0)
    assert extra[0] < 0.05 * extra[peak]  # the capsule carries (almost) nothing
