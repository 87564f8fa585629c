"""fem/ear/elimination.py's ReducedPattern against the plain construction it replaces, bit for bit.

A random constraint map with free, clamped and tied dofs (rows of T with zero, one and several
entries) and a random assembled pattern with repeated entries.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from isj.fem.ear.elimination import ReducedPattern, _unique_nearly_sorted


def _plain(T, rows, cols):
    """The expansion of every product, then np.unique: the construction before."""
    T = sp.csr_matrix(T)
    T.sort_indices()
    count = np.diff(T.indptr)
    cr, cc = count[rows], count[cols]
    nprod = cr * cc
    live = np.flatnonzero(nprod)
    e = np.repeat(live, nprod[live])
    start = np.cumsum(nprod[live]) - nprod[live]
    k = np.arange(e.size) - np.repeat(start, nprod[live])
    i, j = np.divmod(k, cc[e])
    pa, pb = T.indptr[rows[e]] + i, T.indptr[cols[e]] + j
    a, b = T.indices[pa].astype(np.int64), T.indices[pb].astype(np.int64)
    key, inv = np.unique(a * T.shape[1] + b, return_inverse=True)
    return key, inv.ravel(), T.data[pa] * T.data[pb], e


def _constraint_map(n_full=400, seed=1):
    rng = np.random.default_rng(seed)
    kind = rng.choice(3, n_full, p=[0.1, 0.7, 0.2])  # clamped, free, tied to 1-6 masters
    free = np.flatnonzero(kind == 1)
    col = {d: c for c, d in enumerate(free)}
    r, c, v = [], [], []
    for d in range(n_full):
        if kind[d] == 1:
            r, c, v = r + [d], c + [col[d]], v + [1.0]
        elif kind[d] == 2:
            masters = rng.choice(free.size, rng.integers(1, 7), replace=False)
            r += [d] * masters.size
            c += list(masters)
            v += list(rng.standard_normal(masters.size))
    return sp.csr_matrix((v, (r, c)), shape=(n_full, free.size)), rng


def test_the_reduced_pattern_is_the_plain_constructions_bit_for_bit():
    T, rng = _constraint_map()
    rows = rng.integers(0, T.shape[0], 20000)
    cols = np.where(rng.random(rows.size) < 0.5, rows, rng.integers(0, T.shape[0], rows.size))
    order = np.lexsort((cols, rows))  # assembled patterns come mostly in order
    rows, cols = rows[order], cols[order]
    p = ReducedPattern(T, rows, cols)
    key, inv, w, e = _plain(T, rows, cols)
    r, c = np.divmod(key, T.shape[1])
    assert p.indices.tobytes() == c.astype(np.int32).tobytes()
    np.testing.assert_array_equal(
        p.indptr, np.concatenate([[0], np.cumsum(np.bincount(r, minlength=T.shape[1]))])
    )
    ref = sp.csr_matrix((w, (inv, e)), shape=(key.size, rows.size))
    assert (p.map != ref).nnz == 0 and p.map.data.tobytes() == ref.data.tobytes()
    values = rng.standard_normal(rows.size)  # and it reduces a matrix as Tᵀ K T does
    K = sp.csr_matrix((values, (rows, cols)), shape=(T.shape[0],) * 2)
    np.testing.assert_allclose(p.matrix(values).toarray(), (T.T @ K @ T).toarray(), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("keys", [[5, 3, 3, 9, 1, 5], [], [7], [2, 2, 2]])
def test_unique_nearly_sorted_is_numpys_unique(keys):
    keys = np.asarray(keys, np.int64)
    u, inv = _unique_nearly_sorted(keys)
    nu, ninv = np.unique(keys, return_inverse=True)
    assert u.tobytes() == nu.tobytes() and inv.tobytes() == ninv.ravel().astype(np.int64).tobytes()
