"""One pattern, many shifts: fem/ear/reduced_ear.py's ShiftedInterior against scipy's direct solve.

K and M get different patterns on purpose (M has entries where K has none and the reverse), so the
union pattern and the entries placed on it are what is checked, on both backends.
"""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from isj.fem.ear import reduced_ear
from isj.fem.ear.reduced_ear import ShiftedInterior, _values_on


def _pair(n=300, seed=3):
    rng = np.random.default_rng(seed)
    B = sp.random(n, n, density=0.01, random_state=rng)
    K = (B @ B.T + sp.diags(np.full(n, 2.0))).tocsr()  # SPD
    C = sp.random(n, n, density=0.005, random_state=rng)
    M = (C + C.T + sp.diags(np.full(n, 5.0))).tocsr()
    M = M + sp.diags(np.ones(n - 1), 1) + sp.diags(np.ones(n - 1), -1)  # entries K lacks
    return K.tocsr(), M.tocsr()


def test_values_on_the_union_pattern_rebuild_each_matrix():
    K, M = _pair()
    P = (abs(K) + abs(M)).tocsr()
    P.sort_indices()
    for A in (K, M):
        rebuilt = sp.csr_matrix((_values_on(P, A), P.indices, P.indptr), shape=P.shape)
        assert abs(rebuilt - A).max() == 0.0


@pytest.mark.parametrize("backend", ["auto", "superlu"])
def test_each_shift_solves_k_minus_sigma_m(backend, monkeypatch):
    if backend == "superlu":
        monkeypatch.setattr(reduced_ear, "available_backends", lambda: ["superlu"])
    K, M = _pair()
    b = np.random.default_rng(0).standard_normal((K.shape[0], 4))
    with ShiftedInterior(K, M) as shifted:
        for sigma in (0.0, 0.37, 1.9, 0.05):  # not in order: each factor replaces the last
            x = shifted.factor(sigma).solve(b)
            ref = spla.spsolve((K - sigma * M).tocsc(), b)
            assert np.abs(x - ref).max() <= 1e-9 * np.abs(ref).max()


def _interior_inputs(n=300):
    K, M = _pair(n)
    rng = np.random.default_rng(5)
    KIB, MIB = rng.standard_normal((n, 3)), 0.1 * rng.standard_normal((n, 3))
    return K, M, KIB, MIB, rng.standard_normal(n)


def test_interior_basis_is_m_orthonormal_and_holds_the_static_shapes():
    K, M, KIB, MIB, load = _interior_inputs()
    reduced_ear._INTERIOR_BASES.clear()
    psi, phi, f1 = reduced_ear.interior_basis(K, M, KIB, MIB, load, [0.1, 0.2], 0.2, 2, 1e-10)
    np.testing.assert_allclose(psi, -spla.spsolve(K.tocsc(), KIB), rtol=1e-9, atol=1e-12)
    w2 = np.abs(M.diagonal())  # the product the basis is orthonormal in: M's diagonal
    np.testing.assert_allclose(phi.T @ (w2[:, None] * phi), np.eye(phi.shape[1]), atol=1e-9)
    x = spla.spsolve(K.tocsc(), load)  # the pressure's static shape lies in the basis
    left = x - phi @ (phi.T @ (w2 * x))
    assert np.linalg.norm(left) <= 1e-8 * np.linalg.norm(x)
    omega2 = spla.eigsh(K.tocsc(), k=1, M=M.tocsc(), sigma=0.0)[0][0]
    assert f1 == pytest.approx(np.sqrt(omega2) / (2 * np.pi), rel=1e-6)


def test_a_kept_interior_basis_has_the_bits_of_a_new_one():
    K, M, KIB, MIB, load = _interior_inputs()
    args = (K, M, KIB, MIB, load, [0.1, 0.2], 0.2, 2, 1e-10)
    reduced_ear._INTERIOR_BASES.clear()
    first = reduced_ear.interior_basis(*args)
    assert reduced_ear.interior_basis(*args) is first  # kept: no new factorization
    reduced_ear._INTERIOR_BASES.clear()
    again = reduced_ear.interior_basis(*args)
    assert again is not first
    for a, b in zip(first[:2], again[:2], strict=True):
        assert a.tobytes() == b.tobytes()
    other = reduced_ear.interior_basis(K, M, KIB, MIB, 2 * load, [0.1, 0.2], 0.2, 2, 1e-10)
    assert other is not again and len(reduced_ear._INTERIOR_BASES) == 2
