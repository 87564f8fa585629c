"""FE dynamics: cantilever frequencies against beam theory; harmonic response at low frequency."""

import numpy as np
import pytest

from fem.boundary import traction_load
from fem.dynamics import Damping, harmonic, modes
from fem.mesh import TetMesh
from fem.model import ElasticModel
from fem.structured import box_mesh
from isj.design import InvalidParameter, Materials

B, H = 55e-6, 160e-6  # section: x (bending direction), y
RHO, E = 2000.0, 5e9
MAT = Materials(pedicle_e_pa=E, nu=0.0, bone_density_kg_m3=RHO)


def cantilever(length, divisions, order=2):
    m = box_mesh((B, H, length), divisions, origin_m=(-B / 2, -H / 2, 0), region_name="pedicle")
    model = ElasticModel(TetMesh(m.points, m.tets, m.region, ("pedicle",), m.faces), order)
    model.unit_load = traction_load(model.space, "loaded", [1.0, 0.0, 0.0])
    return model


def euler_bernoulli_f1(length, depth, width):
    inertia, area = width * depth**3 / 12, width * depth
    return 1.8751**2 / (2 * np.pi * length**2) * np.sqrt(E * inertia / (RHO * area))


def timoshenko_factor(length, depth):
    """First-order shear and rotary-inertia correction of f1 (ν = 0, κ = 5/6)."""
    r2 = depth**2 / 12  # radius of gyration squared
    return 1 - 0.5 * (1.8751 / length) ** 2 * r2 * (1 + 1 / (5 / 6 * 0.5))


def test_first_bending_frequencies_match_beam_theory():
    L = 20 * B  # slender: L/h = 20 (x) and 6.9 (y)
    model = cantilever(L, (2, 4, 40))
    f, _ = modes(model, MAT, n=2)
    fx = euler_bernoulli_f1(L, B, H) * timoshenko_factor(L, B)
    fy = euler_bernoulli_f1(L, H, B) * timoshenko_factor(L, H)
    assert f[0] == pytest.approx(fx, rel=0.01)
    assert f[1] == pytest.approx(fy, rel=0.03)


def test_frequency_converges_under_refinement():
    """Conforming FE frequencies converge from above, with shrinking steps, to beam theory."""
    L = 10 * B
    exact = euler_bernoulli_f1(L, B, H) * timoshenko_factor(L, B)
    f = [modes(cantilever(L, (n, 2 * n, 10 * n), order=1), MAT, n=1)[0][0] for n in (1, 2, 4)]
    assert f[0] > f[1] > f[2]
    assert f[1] - f[2] < 0.5 * (f[0] - f[1])  # P1: the error falls about 4x per halving
    p2 = modes(cantilever(L, (2, 4, 20)), MAT, n=1)[0][0]
    assert abs(p2 / exact - 1) < 0.005 and abs(p2 / exact - 1) < abs(f[2] / exact - 1)


def test_modes_are_mass_orthonormal():
    model = cantilever(10 * B, (1, 2, 10))
    f, V = modes(model, MAT, n=3)
    M = model.pattern.matrix(model.mass_data(MAT))
    assert np.allclose(V.T @ (M @ V), np.eye(3), atol=1e-8)
    assert np.all(np.diff(f) > 0)


def test_harmonic_far_below_resonance_is_static():
    model = cantilever(5 * B, (1, 2, 5))
    u_static = model.solve_load(MAT, model.unit_load)
    u = harmonic(model, [1.0], MAT, Damping(rayleigh_b_s=0.0), pressure_pa=1.0)[0]
    assert np.allclose(u, u_static, rtol=0, atol=1e-8 * np.abs(u_static).max())
    # a structural loss factor divides the static response by (1 + iη)
    u_eta = harmonic(model, [1.0], MAT, Damping(rayleigh_b_s=0.0, loss_factor=0.1), pressure_pa=1.0)[0]
    assert np.allclose(u_eta, u_static / (1 + 0.1j), atol=1e-8 * np.abs(u_static).max())


def test_damped_response_near_resonance_is_single_mode():
    """Near f1, Rayleigh-damped response ≈ the first mode's: |u| = |φ·f| φ / |ω1² − ω² + iωbω1²|."""
    model = cantilever(10 * B, (1, 2, 10))
    f, V = modes(model, MAT, n=2)
    b = 1e-5
    w = 2 * np.pi * f[0]
    u = harmonic(model, [f[0]], MAT, Damping(rayleigh_b_s=b), pressure_pa=1.0)[0]
    phi = V[:, 0]
    q = (phi @ model.unit_load) / (1j * w * b * w**2)  # at ω = ω1 only damping remains
    tip = np.argmax(np.abs(phi))
    assert abs(u[tip]) == pytest.approx(abs(q * phi[tip]), rel=0.02)


@pytest.mark.parametrize("bad", [[-1.0], [np.nan]])
def test_bad_frequencies_are_refused(bad):
    model = cantilever(5 * B, (1, 1, 2), order=1)
    with pytest.raises(InvalidParameter, match="freq_hz"):
        harmonic(model, bad, MAT)
