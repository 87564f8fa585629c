"""Master–slave elimination over a multi-part dof vector, with a reusable reduced pattern.

The whole ear's full dof vector concatenates parts (shell meshes with 6 dofs
a node, a tetrahedral mesh with 3, rigid bodies with 6). Constraints are of
three kinds, all exact (no penalty stiffness):

- clamped dofs: zero;
- slave dofs: a fixed linear combination of a rigid body's six dofs
  (u_s = u_m + θ_m × (x_s − x_m), and θ_s = θ_m for shell nodes);
- everything else is independent.

So u = T q, with T (n_full × n_reduced) sparse, and K_r = Tᵀ K T, f_r = Tᵀ f.
:class:`ReducedPattern` precomputes, for a fixed list of full-matrix entries
(rows, cols), the sparse linear map from their values to the CSR data of K_r,
so that a part whose values change (the joint model's moduli) costs a single
sparse mat-vec instead of a triple product.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class ConstraintBuilder:
    """Collects clamps and rigid ties on a full dof vector of size ``n_full``, then builds T."""

    def __init__(self, n_full: int):
        self.n_full = int(n_full)
        self._fixed = np.zeros(self.n_full, dtype=bool)
        self._slave = np.zeros(self.n_full, dtype=bool)
        self._rows: list[np.ndarray] = []
        self._cols: list[np.ndarray] = []
        self._vals: list[np.ndarray] = []

    def clamp(self, dofs) -> None:
        """Prescribe zero on ``dofs``."""
        self._fixed[np.asarray(dofs, dtype=np.int64)] = True

    def tie(self, dofs, master_dofs, coefficients) -> None:
        """u[dofs[i]] = Σ_j coefficients[i, j] u[master_dofs[j]].

        Parameters
        ----------
        dofs : (s,) slave dofs, each tied once
        master_dofs : (6,) the master body's dofs, themselves independent
        coefficients : (s, 6) the rigid map's rows
        """
        dofs = np.asarray(dofs, dtype=np.int64)
        if self._slave[dofs].any() or self._fixed[dofs].any():
            raise ValueError("a dof is tied or clamped twice")
        self._slave[dofs] = True
        c = np.asarray(coefficients, dtype=float).reshape(len(dofs), -1)
        md = np.asarray(master_dofs, dtype=np.int64)
        self._rows.append(np.repeat(dofs, len(md)))
        self._cols.append(np.tile(md, len(dofs)))
        self._vals.append(c.ravel())

    def build(self) -> tuple[sp.csr_matrix, np.ndarray]:
        """(T, free): T (n_full × n_free) with u = T q; ``free`` the full indices of q's dofs."""
        free = np.flatnonzero(~(self._fixed | self._slave))
        index = np.full(self.n_full, -1, dtype=np.int64)
        index[free] = np.arange(free.size)
        rows = [free]
        cols = [np.arange(free.size)]
        vals = [np.ones(free.size)]
        for r, c, v in zip(self._rows, self._cols, self._vals, strict=True):
            if (index[c] < 0).any():
                raise ValueError("a master dof is itself tied or clamped")
            keep = v != 0.0
            rows.append(r[keep])
            cols.append(index[c[keep]])
            vals.append(v[keep])
        T = sp.coo_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(self.n_full, free.size),
        ).tocsr()
        T.sum_duplicates()
        T.sort_indices()
        return T, free


def _products(indptr: np.ndarray, rows: np.ndarray, cols: np.ndarray):
    """(e, pa, pb): for each product T[r, a] T[c, b] of entry e = (r, c), in order of e and then
    of (a, b) row-major, e and the positions of its two factors in T's data.

    Most rows of T hold one entry (a free dof is its own reduced dof): those entries have one
    product each and are placed directly; only the tied and clamped ones are expanded.
    """
    count = np.diff(indptr)
    cr, cc = count[rows], count[cols]
    nprod = cr * cc  # entries on clamped dofs have none
    start = np.cumsum(nprod) - nprod
    e = np.repeat(np.arange(rows.size), nprod)
    pa = np.empty(e.size, np.int64)
    pb = np.empty(e.size, np.int64)
    one = np.flatnonzero(nprod == 1)
    pa[start[one]] = indptr[rows[one]]
    pb[start[one]] = indptr[cols[one]]
    many = np.flatnonzero(nprod > 1)
    if many.size:
        n_many = nprod[many]
        k = np.arange(n_many.sum()) - np.repeat(np.cumsum(n_many) - n_many, n_many)  # within each entry
        at = np.repeat(start[many], n_many) + k
        i, j = np.divmod(k, np.repeat(cc[many], n_many))
        pa[at] = indptr[np.repeat(rows[many], n_many)] + i
        pb[at] = indptr[np.repeat(cols[many], n_many)] + j
    return e, pa, pb


def _unique_nearly_sorted(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)``, with a stable sort: the keys of an assembled
    pattern come mostly in order, where it is several times faster than np.unique's quicksort.
    The same arrays either way (the sorted unique keys, and each key's index among them)."""
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    first = np.empty(ordered.size, bool)
    first[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    inv = np.empty(keys.size, np.int64)
    inv[order] = np.cumsum(first) - 1
    return ordered[first], inv


class ReducedPattern:
    """The CSR pattern of Tᵀ K T for K with entries at fixed (rows, cols), and the map values → data.

    Parameters
    ----------
    T : (n_full, n_red) constraint map (CSR)
    rows, cols : (n_e,) positions of the full matrix's entries (duplicates allowed: they add)
    """

    def __init__(self, T: sp.csr_matrix, rows, cols):
        T = sp.csr_matrix(T)
        T.sort_indices()
        n_red = T.shape[1]
        rows = np.asarray(rows, dtype=np.int64)
        cols = np.asarray(cols, dtype=np.int64)
        e, pa, pb = _products(T.indptr, rows, cols)
        a = T.indices[pa].astype(np.int64)
        b = T.indices[pb].astype(np.int64)
        w = T.data[pa] * T.data[pb]
        key, inv = _unique_nearly_sorted(a * n_red + b)
        r, c = np.divmod(key, n_red)
        self.n = n_red
        self.indices = c.astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=n_red))]).astype(np.int64)
        self.map = sp.csr_matrix((w, (inv.ravel(), e)), shape=(key.size, rows.size))
        self.n_entries = rows.size

    @property
    def nnz(self) -> int:
        return self.indices.size

    def matrix(self, values) -> sp.csr_matrix:
        """Tᵀ K T (CSR, sorted indices) for K's entry ``values`` (length n_e)."""
        data = self.map @ np.asarray(values, dtype=float)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))

    def part_matrix(self, entries, values) -> sp.csr_matrix:
        """Tᵀ K T for K with ``values`` at the entries ``entries`` and zeros elsewhere, without
        stored zeros: :meth:`matrix` with its zeros eliminated, the same numbers, and no copy.

        For a part that touches few of K's entries (one region of the joint, one spring set).
        """
        full = np.zeros(self.n_entries)
        full[entries] = values
        data = self.map @ full
        keep = np.flatnonzero(data)
        indptr = np.searchsorted(keep, self.indptr)
        return sp.csr_matrix((data[keep], self.indices[keep], indptr), shape=(self.n, self.n))
