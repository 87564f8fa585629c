"""FE dynamics: cantilever frequencies against beam theory; harmonic response at low frequency."""

import copy

import numpy as np
import pytest
import scipy.sparse as sp
from isj.fem import dynamics
from isj.fem.boundary import traction_load
from isj.fem.dynamics import Damping, _shifted_lanczos, _solve_block, harmonic, modes
from isj.fem.mesh import TetMesh
from isj.fem.model import ElasticModel
from isj.fem.solvers import available_backends, make_complex_symmetric_solver, make_solver
from isj.fem.structured import box_mesh

from isj.design import Materials
from isj.errors import DampingWarning, InvalidParameter

B, H = 55e-6, 160e-6  # section: x (bending direction), y
RHO, E = 2000.0, 5e9
MAT = Materials(pedicle_e_pa=E, nu=0.0, bone_density_kg_m3=RHO)


def cantilever(length, divisions, order=2, solver="auto"):
    m = box_mesh((B, H, length), divisions, origin_m=(-B / 2, -H / 2, 0), region_name="pedicle")
    model = ElasticModel(TetMesh(m.points, m.tets, m.region, ("pedicle",), m.faces), order, solver)
    model.unit_load = traction_load(model.space, "loaded", [1.0, 0.0, 0.0])
    return model


def euler_bernoulli_f1(length, depth, width):
    inertia, area = width * depth**3 / 12, width * depth
    return 1.8751**2 / (2 * np.pi * length**2) * np.sqrt(E * inertia / (RHO * area))


def timoshenko_factor(length, depth):
    """First-order shear and rotary-inertia correction of f1 (ν = 0, κ = 5/6)."""
    r2 = depth**2 / 12  # radius of gyration squared
    return 1 - 0.5 * (1.8751 / length) ** 2 * r2 * (1 + 1 / (5 / 6 * 0.5))


@pytest.mark.slow
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


@pytest.mark.parametrize("solver", ["auto", "superlu"])
def test_harmonic_far_below_resonance_is_static(solver):
    model = cantilever(5 * B, (1, 2, 5), solver=solver)
    u_static = model.solve_load(MAT, model.unit_load)
    u = harmonic(model, [1.0], MAT, Damping.preset("undamped"), pressure_pa=1.0)[0]
    assert np.allclose(u, u_static, rtol=0, atol=1e-8 * np.abs(u_static).max())
    # a structural loss factor divides the static response by (1 + iη)
    u_eta = harmonic(model, [1.0], MAT, Damping.uniform(loss_factor=0.1), pressure_pa=1.0)[0]
    assert np.allclose(u_eta, u_static / (1 + 0.1j), atol=1e-8 * np.abs(u_static).max())


def test_damped_response_near_resonance_is_single_mode():
    """Near f1, Rayleigh-damped response ≈ the first mode's: |u| = |φ·f| φ / |ω1² − ω² + iωbω1²|."""
    model = cantilever(10 * B, (1, 2, 10))
    f, V = modes(model, MAT, n=2)
    b = 1e-5
    w = 2 * np.pi * f[0]
    with pytest.warns(DampingWarning, match="omega\\*b > 0.5 above 7958 Hz"):  # ω1 b = 2.9 here
        u = harmonic(model, [f[0]], MAT, Damping.uniform(rayleigh_b_s=b), pressure_pa=1.0)[0]
    phi = V[:, 0]
    q = (phi @ model.unit_load) / (1j * w * b * w**2)  # at ω = ω1 only damping remains
    tip = np.argmax(np.abs(phi))
    assert abs(u[tip]) == pytest.approx(abs(q * phi[tip]), rel=0.02)


@pytest.mark.parametrize("bad", [[-1.0], [np.nan]])
def test_bad_frequencies_are_refused(bad):
    model = cantilever(5 * B, (1, 1, 2), order=1)
    with pytest.raises(InvalidParameter, match="freq_hz"):
        harmonic(model, bad, MAT)


needs_pardiso = pytest.mark.skipif("pardiso" not in available_backends(), reason="needs PARDISO (pypardiso)")


def _complex_symmetric(n=60, seed=0):
    """A sparse complex symmetric, non-Hermitian, indefinite real part: K(1 + 0.3i) − 2M, like K_dyn."""
    rng = np.random.default_rng(seed)
    R = sp.random(n, n, density=0.08, random_state=rng)
    K = (R @ R.T + sp.identity(n)).tocsr()  # SPD
    M = sp.diags(rng.uniform(0.5, 1.5, n)) + 0.1 * (R + R.T)
    K, M = K + 0 * M, M + 0 * K  # one shared pattern
    return (K * (1 + 0.3j) - 2.0 * M).tocsr(), K.tocsr()


@needs_pardiso
def test_complex_pardiso_matches_superlu_and_dense():
    Z, K = _complex_symmetric()
    assert abs(Z - Z.T).max() == 0 and abs(Z - Z.conj().T).max() > 0
    b = np.random.default_rng(1).normal(size=(Z.shape[0], 2)) + 1j
    exact = np.linalg.solve(Z.toarray(), b)
    xs = []
    for backend, perm in (("auto", None), ("superlu", None), ("auto", make_solver(K, "pardiso").perm)):
        s = make_complex_symmetric_solver(Z, backend, perm)
        s.factor(Z)
        x = s.solve(b)
        s.free()
        assert x.shape == b.shape and np.iscomplexobj(x)
        assert np.linalg.norm(x - exact) < 1e-12 * np.linalg.norm(exact)
        xs.append(x)
    assert np.linalg.norm(xs[0] - xs[1]) < 1e-12 * np.linalg.norm(xs[1])
    assert np.linalg.norm(xs[0] - xs[2]) < 1e-12 * np.linalg.norm(xs[0])  # with the static ordering


@needs_pardiso
@pytest.mark.filterwarnings("ignore::isj.errors.DampingWarning")
@pytest.mark.parametrize(
    "damping",
    [
        Damping(),  # the published loss factors: non-proportional, the projected solve
        Damping.preset("uniform-rayleigh"),
        Damping.uniform(50.0, 0.0, 0.05),
        Damping.preset("undamped"),
    ],
)
@pytest.mark.slow
def test_harmonic_matches_the_block_solve(coarse_model, damping):
    """Krylov (the default) and complex-symmetric PARDISO against the real 2n × 2n block system."""
    m = Materials(pedicle_e_pa=3e9)
    freqs = [100.0, 20e3]  # the coarse model's first resonance is near 20 kHz
    u = harmonic(coarse_model, freqs, m, damping, pressure_pa=1.0)
    u_direct = harmonic(coarse_model, freqs, m, damping, pressure_pa=1.0, method="direct")
    red = coarse_model.reduction
    K, L, C, M = dynamics.damping_matrices(coarse_model, m, damping)
    f = red.restrict(coarse_model.unit_load)
    for i, fr in enumerate(freqs):
        w = 2 * np.pi * fr
        A = K - w**2 * M
        B = L + w * C
        ref = red.expand(_solve_block(A, B, f))
        assert np.linalg.norm(u[i] - ref) < 1e-8 * np.linalg.norm(ref)  # measured ≤ 4e-10
        assert np.linalg.norm(u_direct[i] - ref) < 1e-8 * np.linalg.norm(ref)


@pytest.mark.slow
def test_harmonic_superlu_fallback(coarse_model):
    """``solver="superlu"`` (and machines without PARDISO) solve the complex matrix with SuperLU."""
    m = Materials(pedicle_e_pa=3e9)
    slu = copy.copy(coarse_model)  # same mesh and matrices, SuperLU asked for
    slu._solver_name, slu._solver = "superlu", None
    u_slu = harmonic(slu, [5e3], m, pressure_pa=1.0, method="direct")[0]
    u = harmonic(coarse_model, [5e3], m, pressure_pa=1.0)[0]
    assert np.linalg.norm(u - u_slu) < 1e-8 * np.linalg.norm(u_slu)  # measured 2e-10


def test_shifted_lanczos_solves_every_shift():
    """(I + c K⁻¹M) x = K⁻¹f for complex and real shifts, one Krylov space, against dense solves."""
    rng = np.random.default_rng(2)
    n = 40
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    K = Q @ np.diag(np.geomspace(1, 1e4, n)) @ Q.T  # SPD, spread spectrum
    M = np.diag(rng.uniform(0.5, 2.0, n))
    f = rng.normal(size=n)
    c = np.array([0.0, -0.5 + 0.1j, -30.0 + 3.0j, -2e3 - 1e3j, 0.3])
    x, ok, _ = _shifted_lanczos(lambda b: np.linalg.solve(K, b), sp.csr_matrix(M), f, c, tol=1e-12, kmax=n)
    assert ok.all()
    for j, cj in enumerate(c):
        exact = np.linalg.solve(K + cj * M, f)
        assert np.linalg.norm(x[j] - exact) < 1e-9 * np.linalg.norm(exact)


@pytest.mark.parametrize("solver", ["auto", "superlu"])
def test_harmonic_falls_back_to_direct(monkeypatch, solver):
    """Frequencies where Lanczos does not converge are solved directly, with the same answer."""
    model = cantilever(10 * B, (1, 2, 10), solver=solver)
    freqs = [1e3, 4.6e4, 1e5]  # around the first bending frequency (4.62e4 Hz)
    d = Damping.uniform(rayleigh_b_s=1e-7, loss_factor=0.01)
    direct, solved = dynamics._direct, []

    def spy(model, K, M, f, alpha, beta, damped):
        solved.append(alpha.size)
        return direct(model, K, M, f, alpha, beta, damped)

    monkeypatch.setattr(dynamics, "_direct", spy)
    u = harmonic(model, freqs, MAT, d, pressure_pa=1.0)
    assert solved == []  # Lanczos converged everywhere, on resonance too
    monkeypatch.setattr(dynamics, "KRYLOV_MAX_ITERATIONS", 1)
    u_fallback = harmonic(model, freqs, MAT, d, pressure_pa=1.0)
    assert solved == [3]
    u_direct = harmonic(model, freqs, MAT, d, pressure_pa=1.0, method="direct")
    for i in range(len(freqs)):
        assert np.linalg.norm(u_fallback[i] - u_direct[i]) < 1e-12 * np.linalg.norm(u_direct[i])
        assert np.linalg.norm(u[i] - u_direct[i]) < 1e-8 * np.linalg.norm(u_direct[i])


def test_bad_method_is_refused():
    with pytest.raises(InvalidParameter, match="method"):
        harmonic(cantilever(5 * B, (1, 1, 2), order=1), [1.0], MAT, method="lanczos")


@pytest.mark.slow
@needs_pardiso
def test_harmonic_reuses_the_static_ordering(coarse_model):
    """After a static solve the direct harmonic solve reuses its ordering; same answer either way."""
    m = Materials(pedicle_e_pa=3e9)
    coarse_model.static(m)
    perm = coarse_model._solver.perm
    assert sorted(perm) == list(range(1, coarse_model.n_dofs + 1))
    fresh = copy.copy(coarse_model)  # no static solver: PARDISO orders the complex matrix itself
    fresh._solver = None
    u = harmonic(coarse_model, [3e3], m, method="direct")
    u0 = harmonic(fresh, [3e3], m, method="direct")
    assert np.linalg.norm(u - u0) < 1e-12 * np.linalg.norm(u0)
