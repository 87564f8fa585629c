"""Vectorised assembly of linear elasticity on tetrahedra, one matrix per region.

Isotropic elasticity splits into a λ part and a μ part,

    a(u, v) = λ (div u)(div v) + 2μ ε(u) : ε(v),

so each region r is assembled once into K_λ,r and K_μ,r. With Young's modulus
E_r and Poisson's ratio ν, λ = E ν / ((1+ν)(1−2ν)) and μ = E / (2(1+ν)), and

    K = Σ_r E_r (λ̂(ν) K_λ,r + μ̂(ν) K_μ,r)

costs a sum of vectors: neither a new set of moduli nor a new ν needs
reassembly. All matrices share one CSR pattern (3×3 node blocks, dof = 3·node +
component); a region stores only the entries its elements touch.

No Python loop runs over elements: element matrices come from reference
integrals (exact for straight-sided tetrahedra) through ``einsum``, in chunks to
bound memory.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .elements import barycentric, reference_mass, shape_gradients
from .space import Space

_CHUNK = 8192  # elements per block: bounds peak memory (~60 MB for P2)


def lame_unit(nu: float) -> tuple[float, float]:
    """λ and μ per unit Young's modulus for Poisson's ratio ``nu``."""
    return nu / ((1 + nu) * (1 - 2 * nu)), 1 / (2 * (1 + nu))


@dataclass(frozen=True)
class Pattern:
    """Shared CSR pattern of all matrices on a space, organised in 3×3 node blocks.

    A node pair q = (I, J) of the node graph owns the nine entries
    ``block_pos[q, k, l]`` of the CSR data, coupling dof 3I+k with dof 3J+l;
    ``pair[e, i, j]`` is the node pair of element e's local nodes i and j.
    """

    indptr: np.ndarray
    indices: np.ndarray
    pair: np.ndarray
    pair_row: np.ndarray
    pair_col: np.ndarray
    block_pos: np.ndarray
    n_dofs: int

    @property
    def nnz(self) -> int:
        return self.indices.size

    @property
    def n_pairs(self) -> int:
        return self.pair_row.size

    def rows(self) -> np.ndarray:
        return np.repeat(np.arange(self.n_dofs), np.diff(self.indptr))

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_dofs,) * 2)


def _unique_inverse(keys: np.ndarray, bound: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)`` for keys in [0, ``bound``), the same arrays.

    Each key is packed with its index into one int64 and sorted by value
    (numpy's vectorised sort, several times faster here than the argsort inside
    ``np.unique``); the index bits say where each sorted key came from.
    """
    shift = max(int(keys.size - 1).bit_length(), 1)
    if bound <= 0 or (bound - 1).bit_length() + shift > 62:  # does not fit in one int64
        return np.unique(keys, return_inverse=True)
    packed = np.sort((keys << shift) | np.arange(keys.size, dtype=np.int64))
    sorted_keys = packed >> shift
    new = np.empty(keys.size, dtype=bool)
    new[:1] = True
    np.not_equal(sorted_keys[1:], sorted_keys[:-1], out=new[1:])
    inv = np.empty(keys.size, dtype=np.intp)
    inv[packed & ((1 << shift) - 1)] = np.cumsum(new) - 1
    return sorted_keys[new], inv


def build_pattern(space: Space) -> Pattern:
    """Sparsity pattern of the dof matrix, built from the node graph (9× smaller)."""
    cells = space.cells
    ne, nn = cells.shape
    nnodes = space.n_nodes
    keys = cells[:, :, None].astype(np.int64) * nnodes + cells[:, None, :]
    uniq, inv = _unique_inverse(keys.ravel(), nnodes * nnodes)
    itype = np.int32 if uniq.size < 2**31 else np.int64
    pair_row, pair_col = np.divmod(uniq, nnodes)
    deg = np.bincount(pair_row, minlength=nnodes)
    nptr = np.concatenate([[0], np.cumsum(deg)])
    # dof row 3I+k holds 3·deg(I) columns (3J+l, J sorted, l = 0..2): it starts
    # at 9·nptr[I] + 3k·deg(I), and pair q = (I, J) sits 3(q − nptr[I]) further
    k = np.arange(3)
    base = 9 * nptr[pair_row] + 3 * (np.arange(uniq.size) - nptr[pair_row])
    block_pos = base[:, None, None] + 3 * k[:, None] * deg[pair_row][:, None, None] + k[None, :]
    indices = np.empty(9 * uniq.size, dtype=itype)
    indices[block_pos] = (3 * pair_col[:, None, None] + k[None, None, :]).astype(itype)
    indptr = np.concatenate([[0], np.cumsum(np.repeat(3 * deg, 3))])
    return Pattern(
        indptr=indptr,
        indices=indices,
        pair=inv.reshape(ne, nn, nn).astype(itype),
        pair_row=pair_row,
        pair_col=pair_col,
        block_pos=block_pos,
        n_dofs=3 * nnodes,
    )


@dataclass(frozen=True)
class RegionMatrices:
    """One region's matrices as 3×3 blocks on the node pairs ``pairs`` it touches.

    ``lam``/``mu``: (n, 3, 3) blocks of the λ and μ parts of the stiffness for
    unit λ and μ (N/m per Pa); ``mass``: (n,) scalar blocks (times the 3×3
    identity) of the consistent mass for unit density (kg per kg/m³), filled in
    by :func:`assemble_mass` when dynamics need it.
    """

    pairs: np.ndarray
    lam: np.ndarray
    mu: np.ndarray
    mass: np.ndarray | None = None
    positions: np.ndarray | None = None  # CSR data positions of the blocks, cached
    combined: tuple | None = None  # (ratio, lam + ratio · mu) of the last ratio asked, cached

    def lam_plus(self, ratio: float) -> np.ndarray:
        """The blocks ``lam + ratio · mu`` (one modulus's stiffness per unit λ at μ/λ = ``ratio``).

        Every term of a stiffness sum scales a region's λ and μ parts by the same E, so their
        ratio is fixed by ν: the blocks are made once per ratio and kept (the last one), which
        makes each later sum one product instead of three (docs/performance.md §8.9).
        """
        kept = self.combined
        if kept is None or kept[0] != ratio:
            kept = (ratio, self.lam + ratio * self.mu)
            object.__setattr__(self, "combined", kept)
        return kept[1]


# Hammer's 4-point rule, degree 2: exact for products of P2 gradients on
# straight-sided tetrahedra; weights are equal and positive (square roots below).
_A, _B = 0.5854101966249685, 0.1381966011250105
_HAMMER = np.array([[_B, _B, _B], [_A, _B, _B], [_B, _A, _B], [_B, _B, _A]])


def _gradient_products(space: Space, e: np.ndarray) -> np.ndarray:
    """A[e, (i,k), (j,l)] = ∫_e ∂_k N_i ∂_l N_j dV for elements ``e``, shape (e, 3n, 3n)."""
    gref = shape_gradients(space.order, barycentric(_HAMMER))  # (q, n, a)
    q, n, _ = gref.shape
    g = np.matmul(gref.reshape(1, q * n, 3), space.inv_jac[e])  # (e, q·n, k)
    g = g.reshape(e.size, q, n * 3) * np.sqrt(space.det[e] / (6 * q))[:, None, None]
    return np.matmul(g.transpose(0, 2, 1), g)


def _region_pairs(pattern: Pattern, sel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Node pairs touched by elements ``sel`` and a map from pair id to local id."""
    touched = np.zeros(pattern.n_pairs, dtype=bool)
    touched[pattern.pair[sel].ravel()] = True
    pairs = np.flatnonzero(touched)
    local = np.full(pattern.n_pairs, -1, dtype=np.int64)
    local[pairs] = np.arange(pairs.size)
    return pairs, local


def assemble_regions(space: Space, pattern: Pattern) -> dict[str, RegionMatrices]:
    """Assemble K_λ and K_μ of every region (unit λ and μ).

    One block matrix of gradient products A[(i,k),(j,l)] = ∫ ∂_k N_i ∂_l N_j
    is assembled per region; then K_λ = A and, per 3×3 node block,
    K_μ = tr(A) I + Aᵀ (K_μ[(i,k),(j,l)] = δ_kl Σ_m ∫ ∂_m N_i ∂_m N_j + ∫ ∂_l N_i ∂_k N_j).
    """
    kl = np.arange(9).reshape(3, 3)
    out = {}
    for rid, name in enumerate(space.region_names):
        sel = np.flatnonzero(space.region == rid)
        if sel.size == 0:
            continue
        pairs, local = _region_pairs(pattern, sel)
        A = np.zeros(9 * pairs.size)
        for start in range(0, sel.size, _CHUNK):
            e = sel[start : start + _CHUNK]
            # entry (e, i, k, j, l) goes to block entry (local pair of i, j; k; l)
            lp = local[pattern.pair[e]]  # (e, i, j)
            where = 9 * lp[:, :, None, :, None] + kl[None, None, :, None, :]
            A += np.bincount(where.ravel(), weights=_gradient_products(space, e).ravel(), minlength=A.size)
        A = A.reshape(-1, 3, 3)
        mu = A.transpose(0, 2, 1) + np.trace(A, axis1=1, axis2=2)[:, None, None] * np.eye(3)
        out[name] = RegionMatrices(pairs=pairs, lam=A, mu=mu)
    return out


def assemble_mass(space: Space, pattern: Pattern, regions: dict[str, RegionMatrices]) -> None:
    """Fill in the consistent mass (unit density) of every region, in place."""
    m_ref = reference_mass(space.order)
    for rid, name in enumerate(space.region_names):
        if name not in regions:
            continue
        rm = regions[name]
        sel = np.flatnonzero(space.region == rid)
        local = np.full(pattern.n_pairs, -1, dtype=np.int64)
        local[rm.pairs] = np.arange(rm.pairs.size)
        vals = space.det[sel][:, None, None] * m_ref[None]
        mass = np.bincount(local[pattern.pair[sel]].ravel(), weights=vals.ravel(), minlength=rm.pairs.size)
        object.__setattr__(rm, "mass", mass)


def combine(
    pattern: Pattern,
    regions: dict[str, RegionMatrices],
    coef: dict[str, tuple[float, float]],
    part: str = "stiffness",
) -> np.ndarray:
    """CSR data of Σ_r over regions on the shared pattern.

    For ``part="stiffness"``, ``coef[r] = (λ_r, μ_r)`` in Pa; for ``part="mass"``,
    ``coef[r] = (ρ_r, _)`` in kg/m³ (call :func:`assemble_mass` first).

    Each region's blocks are added on the solver's threads (:func:`fem.solvers.solver_threads`),
    each thread a slice of its node pairs. A region's positions are distinct, and the regions
    are added one after the other, so every entry sums its terms in the same order on any number
    of threads: the same bits (tests/test_assembly_threads.py).
    """
    from .solvers import solver_threads

    data = np.zeros(pattern.nnz)
    threads = solver_threads()
    for name, rm in regions.items():
        _add_region(data, _positions(pattern, rm), rm, coef[name], part, threads)
    return data


#: Node pairs below which a region is added on one thread (a thread's start costs more).
_MIN_PAIRS_PER_THREAD = 20_000


def _add_region(data, positions, rm: RegionMatrices, coef, part: str, threads: int) -> None:
    """``data[positions] += blocks`` for one region, its pairs split among ``threads``.

    A stiffness term is added through two buffers made here, each thread filling its own slice
    (``take``, ``multiply``, ``add``, ``put``): the threads allocate nothing, so their malloc
    arenas do not keep a sum's temporaries (docs/performance.md §8.10). The arithmetic is
    ``data[p] + E·blocks[p]``, as with one thread.
    """
    from .solvers import on_solver_threads

    n_pairs = rm.pairs.size
    parts = max(1, min(threads, n_pairs // _MIN_PAIRS_PER_THREAD))
    a, b = coef
    if parts == 1 or part != "stiffness":
        data[positions] += _blocks(rm, coef, part).ravel()
        return
    scale, flat = (b, rm.mu.reshape(-1)) if a == 0 else (a, rm.lam_plus(b / a).reshape(-1))
    summed, term = np.empty(flat.size), np.empty(flat.size)
    bounds = 9 * np.linspace(0, n_pairs, parts + 1).astype(np.int64)

    def add(i: int) -> None:
        part_of = slice(int(bounds[i]), int(bounds[i + 1]))
        np.take(data, positions[part_of], out=summed[part_of], mode="clip")  # "raise" would buffer out
        np.multiply(scale, flat[part_of], out=term[part_of])
        np.add(summed[part_of], term[part_of], out=summed[part_of])
        np.put(data, positions[part_of], summed[part_of], mode="clip")

    on_solver_threads(add, range(parts))


def _blocks(rm: RegionMatrices, coef: tuple[float, float], part: str) -> np.ndarray:
    """(p, 3, 3) blocks of one region's term of :func:`combine`."""
    a, b = coef
    if part == "stiffness":
        return b * rm.mu if a == 0 else a * rm.lam_plus(b / a)
    if rm.mass is None:
        raise ValueError("mass not assembled: call fem.assembly.assemble_mass first")
    return a * rm.mass[:, None, None] * np.eye(3)


def _positions(pattern: Pattern, rm: RegionMatrices) -> np.ndarray:
    """Positions in the pattern's data of a region's block entries, gathered once: within a
    region they are distinct, and pairs on a region boundary accumulate across regions."""
    if rm.positions is None:
        object.__setattr__(rm, "positions", pattern.block_pos[rm.pairs].ravel())
    return rm.positions


def region_entries(
    pattern: Pattern, rm: RegionMatrices, coef: tuple[float, float], part: str = "stiffness"
) -> tuple[np.ndarray, np.ndarray]:
    """One region's term of :func:`combine` as (positions in the pattern's data, distinct; values).

    ``combine(pattern, {name: rm}, {name: coef}, part)`` is zero but at these positions, where it
    holds these values.
    """
    return _positions(pattern, rm), _blocks(rm, coef, part).ravel()
