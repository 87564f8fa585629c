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
