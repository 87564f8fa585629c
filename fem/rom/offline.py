"""Offline stage: the affine parts of the FE model, the reduced bases and the greedy (docs/rom.md §10.3).

With ν fixed, the free-free stiffness is K(μ) = Σ_r θ_r A_r with θ_r = E_r (Pa) and
A_r = λ̂(ν) K_λ,r + μ̂(ν) K_μ,r, each positive semi-definite; the load for unit
pressure f and the functionals ℓ_α, ℓ_β (rows of :func:`isj.fem.angles.angle_operator`,
α = ℓ_αᵀ u) do not depend on μ. The X inner product is the energy of the reference
design μ̄ (the log-centre of the domain): ⟨v, w⟩_X = vᵀ K(μ̄) w, factored once.

Three reduced spaces are built: the primal space (snapshots u(μ)) and one dual space
per output (K(μ) ψ = −ℓ). Each greedy step solves the FE model at the training design
with the largest relative output bound, with one factorization for the three loads.
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from isj.cachefile import DamagedEntry, canonical_json, discard, read_npz_entry, write_npz_entry
from isj.design import REGIONS
from isj.design_space import DesignSpace

from ..assembly import combine, lame_unit
from ..solvers import make_solver
from .local import relative_bounds
from .online import DUALS, SPACES

#: A new representer whose X-norm after orthogonalisation falls below this fraction of its own
#: is dropped (it adds nothing the basis does not span: the six region representers of a
#: basis vector v add up to v itself, Σ_r θ̄_r X⁻¹A_r v = v); its remainder enters its error radius.
DROP_TOL = 1e-11


def affine_parts(
    model, nu: float
) -> tuple[sp.csr_matrix, np.ndarray, list[sp.csr_matrix], np.ndarray, np.ndarray]:
    """The affine decomposition of the free-free problem for Poisson's ratio ``nu``.

    Returns
    -------
    pattern : csr_matrix
        The free-free pattern (its data is irrelevant): every A_r is given on it.
    data : (6, nnz) array
        A_r's entries on ``pattern`` per region, :data:`isj.design.REGIONS` order (N/m per Pa),
        so that K(θ) is one vector sum ``θ @ data`` on a fixed pattern.
    mats : list of csr_matrix
        A_r with only its own entries (a region touches a fraction of the pattern), for products.
    f : (n,) array
        The load for unit pressure (N per Pa).
    ell : (2, n) array
        ℓ_α and ℓ_β (rad per m).
    """
    lam, mu = lame_unit(nu)
    data = np.zeros((len(REGIONS), model.reduction.keep.size))
    for i, r in enumerate(REGIONS):
        if r in model.regions:
            data[i] = combine(model.pattern, {r: model.regions[r]}, {r: (lam, mu)})[model.reduction.keep]
    pattern = model.reduction.matrix(np.zeros(model.pattern.nnz))
    mats = []
    for row in data:
        A = sp.csr_matrix((row, pattern.indices.copy(), pattern.indptr.copy()), shape=pattern.shape)
        A.eliminate_zeros()  # in place: hence the copies, the pattern's arrays stay whole
        mats.append(A)
    f = model.reduction.restrict(model.unit_load)
    ell = np.asarray(model.angles[:2])[:, model.reduction.free]
    return pattern, data, mats, f, ell


class Columns:
    """A matrix that grows by columns without copying what it holds (capacity doubles).

    Column-major, so that a new column is one contiguous write and the view is BLAS-ready.
    """

    def __init__(self, n: int):
        self._a = np.zeros((n, 8), order="F")
        self.size = 0

    def append(self, v: np.ndarray) -> None:
        if self.size == self._a.shape[1]:
            grown = np.zeros((self._a.shape[0], 2 * self.size), order="F")
            grown[:, : self.size] = self._a
            self._a = grown
        self._a[:, self.size] = v
        self.size += 1

    @property
    def matrix(self) -> np.ndarray:
        """(n, size) view of the columns held."""
        return self._a[:, : self.size]

    def __len__(self) -> int:
        return self.size

    def __iter__(self):
        return iter(self.matrix.T)


class Representers:
    """Riesz representers of a residual's terms, kept as Z = Q R with Q X-orthonormal.

    Columns come in blocks (the six region representers of a new basis vector); R is stored
    column by column, each as long as Q was after its block. A block is projected out of Q
    twice (block classical Gram–Schmidt in the X inner product, BLAS-3), then orthonormalised
    within itself through the eigenvectors of its X-Gram matrix, then cleaned up once more
    against Q and itself. Directions below :data:`DROP_TOL` of a column's norm are dropped (the
    six region representers of v add up to v, so a block can be nearly dependent on Q); what a
    column loses that way is measured and goes into its error radius.

    The X-images XQ of the orthonormal vectors are kept beside them, so that a block costs
    four sparse products with X (its own image, the new directions' image twice, and the
    remainder's image for its measured loss) instead of one per projection: the products
    were most of the offline time. The images only steer the orthogonalisation; everything
    the bound rests on (the remainder's X-norm, Q's departure from X-orthonormality,
    measured at the end by :meth:`Greedy.arrays`) is computed with X itself.
    """

    def __init__(self, X: sp.csr_matrix):
        self.X = X
        self.Q = Columns(X.shape[0])
        self.XQ = Columns(X.shape[0])
        self.cols: list[np.ndarray] = []
        self.eta: list[float] = []

    def _project_out(self, W: np.ndarray, XW: np.ndarray, passes: int = 2) -> np.ndarray:
        """Remove Q's components from ``W`` and its image ``XW`` (in place); the coefficients removed."""
        H = np.zeros((len(self.Q), W.shape[1]))
        for _ in range(passes):
            P = self.XQ.matrix.T @ W  # = Qᵀ X W, X symmetric
            W -= self.Q.matrix @ P
            XW -= self.XQ.matrix @ P
            H += P
        return H

    def append(self, Z: np.ndarray, err: np.ndarray) -> None:
        """Append representers ``Z`` (n, j) whose X-norm errors are at most ``err`` (j,)."""
        Z = np.asarray(Z, dtype=float).reshape(Z.shape[0], -1)
        XW = self.X @ Z
        znorm = np.sqrt(np.maximum(np.einsum("ij,ij->j", Z, XW), 0.0))
        W = Z.copy()
        H = self._project_out(W, XW)
        # within the block: X-orthonormal directions of W from its Gram matrix's eigenvectors,
        # keeping those above DROP_TOL of the block's largest column
        lam, U = np.linalg.eigh(W.T @ XW)
        keep = lam > (DROP_TOL * max(float(znorm.max()), 1e-300)) ** 2
        Qb = W @ (U[:, keep] / np.sqrt(lam[keep]))
        # the Gram matrix squared the conditioning: clean up against Q and within, with X's own image
        XQb = self.X @ Qb
        self._project_out(Qb, XQb, passes=1)
        lam2, U2 = np.linalg.eigh(Qb.T @ XQb)
        Qb = Qb @ (U2 / np.sqrt(np.maximum(lam2, 1e-300)))
        XQb = self.X @ Qb
        T = XQb.T @ W
        E = W - Qb @ T  # what the kept directions miss of each column
        XE = self.X @ E
        lost = np.sqrt(np.maximum(np.einsum("ij,ij->j", E, XE), 0.0))
        H = H + self.XQ.matrix.T @ E  # E's part along Q, if the clean-up left one
        for q, xq in zip(Qb.T, XQb.T, strict=True):
            self.Q.append(q)
            self.XQ.append(xq)
        for j in range(Z.shape[1]):
            self.cols.append(np.concatenate([H[:, j], T[:, j]]))
            self.eta.append(float(err[j]) + float(lost[j]) + 16 * np.finfo(float).eps * float(znorm[j]))

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(R (p, m), η (m,)) with p the number of orthonormal vectors."""
        p = len(self.Q)
        R = np.zeros((p, len(self.cols)))
        for j, h in enumerate(self.cols):
            R[: h.size, j] = h
        return R, np.array(self.eta)


class ReducedSpace:
    """One reduced space: X-orthonormal basis, reduced region matrices, residual representers."""

    def __init__(self, X, mats, rhs, z, err):
        self.X, self.mats, self.rhs = X, mats, rhs
        self.V = Columns(X.shape[0])
        self.XV = Columns(X.shape[0])  # X V, so that orthogonalising costs one product with X
        self.A = np.zeros((len(mats), 0, 0))
        self.g = np.zeros(0)
        self.rep = Representers(X)
        self.rep.append(z, err)  # the load's representer X⁻¹g

    @property
    def k(self) -> int:
        return len(self.V)

    def orthonormalize(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(``v`` made X-orthogonal to the basis and X-normalized, its image X v); None if it adds nothing.

        The basis need not be exactly X-orthonormal for the bound (the reduced matrices and the
        representers are those of the vectors actually kept), so the image is updated along
        with ``v`` instead of multiplied again.
        """
        V, XV = self.V.matrix, self.XV.matrix
        w = v.copy()
        Xw = self.X @ w
        norm0 = float(np.sqrt(max(w @ Xw, 0.0)))
        for _ in range(2):
            P = XV.T @ w
            w -= V @ P
            Xw -= XV @ P
        norm = float(np.sqrt(max(w @ Xw, 0.0)))
        return None if norm <= 1e-10 * norm0 else (w / norm, Xw / norm)

    def extend(self, v: np.ndarray, Xv: np.ndarray, Av: np.ndarray) -> None:
        """Add X-orthonormal ``v``, its image ``Xv`` and its region images ``Av`` (6, n)."""
        k = self.k
        A = np.zeros((len(self.mats), k + 1, k + 1))
        A[:, :k, :k] = self.A
        col = np.column_stack([Av @ self.V.matrix, Av @ v])  # (6, k + 1)
        A[:, :, k] = col
        A[:, k, :] = col
        self.A = A
        self.g = np.append(self.g, v @ self.rhs)
        self.V.append(v)
        self.XV.append(Xv)


#: Every this many solves with X, one is refined to measure the direct solver's accuracy.
REFINE_EVERY = 8


class XSolver:
    """Solves with X = K(μ̄), factored once, and an error radius for each solution (X-norm).

    A direct solve is accurate to round-off; one step of iterative refinement measures how
    accurate. Refining every solve would double the offline time, so the first solve and
    every :data:`REFINE_EVERY`-th are refined, and every other solution gets the error radius
    10 × the largest relative correction seen × its own X-norm (at least 1e-13 relative).
    """

    def __init__(self, solver, X):
        self.solver, self.X = solver, X
        self.calls = 0
        self.rel = 1e-14
        self.norms = np.zeros(0)  # the last call's solutions' X-norms

    def __call__(self, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        B = np.asarray(B, dtype=float).reshape(B.shape[0], -1)
        Z = np.asarray(self.solver.solve(B)).reshape(B.shape)
        XZ = self.X @ Z
        znorm = np.sqrt(np.maximum(np.einsum("ij,ij->j", Z, XZ), 0.0))
        if self.calls % REFINE_EVERY == 0:
            D = np.asarray(self.solver.solve(B - XZ)).reshape(B.shape)
            dnorm = np.sqrt(np.maximum(np.einsum("ij,ij->j", D, self.X @ D), 0.0))
            self.rel = max(self.rel, float(np.max(dnorm / np.maximum(znorm, 1e-300))))
            Z = Z + D
        self.calls += 1
        self.norms = znorm
        return Z, np.maximum(10 * self.rel, 1e-13) * znorm


def _same_pattern(xs, X: sp.csr_matrix, solver: str):
    """A second solver for X's pattern, reusing ``xs``'s fill-reducing ordering where it has one (PARDISO)."""
    perm = getattr(xs, "perm", None)
    if perm is not None:
        try:
            return type(xs)(X, perm=perm)
        except TypeError:  # a backend without a given ordering
            pass
    return make_solver(X, solver)


class Greedy:
    """The weak greedy over a training set, driven by the relative output bounds.

    Parameters
    ----------
    model : an assembled :class:`isj.fem.model.PedicleJointModel`
    space : the design space (ν and the incus modulus fixed)
    """

    def __init__(self, model, space: DesignSpace, solver: str = "auto"):
        t0 = time.perf_counter()
        self.model, self.space = model, space
        self.pattern, self.data, self.mats, self.f, self.ell = affine_parts(model, space.nu)
        self.theta_bar = space.theta(space.center()[None])[0]
        self.X = self._stiffness(self.theta_bar)
        self._xs = make_solver(self.X, solver)
        self._xs.factor(self.X)
        self._fe = _same_pattern(self._xs, self.X, solver)
        self.xsolve = XSolver(self._xs, self.X)
        rhs = {"u": self.f, "a": -self.ell[0], "b": -self.ell[1]}
        Z0, err0 = self.xsolve(np.column_stack([rhs[s] for s in SPACES]))  # one solve for the three loads
        self.spaces = {
            s: ReducedSpace(self.X, self.mats, rhs[s], Z0[:, [j]], err0[[j]]) for j, s in enumerate(SPACES)
        }
        self.cross = {d: np.zeros((len(self.mats), 0, 0)) for d in DUALS}  # Wᵀ A_r V per dual
        self.snapshots: list[np.ndarray] = []
        self.derive_rel = 0.0  # the derived region representers' largest relative miss (measured)
        self._rep_calls = 0
        self.fe_roundoff: list[float] = []
        self.timings_s = {"setup": time.perf_counter() - t0, "fe": 0.0, "representers": 0.0}

    def _stiffness(self, theta: np.ndarray) -> sp.csr_matrix:
        """K(θ) on the fixed pattern: one vector sum (every A_r is stored on that pattern)."""
        return sp.csr_matrix(
            (theta @ self.data, self.pattern.indices, self.pattern.indptr), shape=self.pattern.shape
        )

    def add_snapshot(self, e: np.ndarray) -> None:
        """FE solves at design ``e`` (5,) for the three loads; extend every space."""
        t0 = time.perf_counter()
        theta = self.space.theta(np.asarray(e, dtype=float)[None])[0]
        B = np.column_stack([self.spaces[s].rhs for s in SPACES])
        if np.array_equal(theta, self.theta_bar):
            sol = self.xsolve(B)[0]  # X is K(μ̄), already factored
        else:
            K = self._stiffness(theta)
            self._fe.factor(K)
            U = np.asarray(self._fe.solve(B)).reshape(B.shape)
            D = np.asarray(self._fe.solve(B - K @ U)).reshape(B.shape)
            sol = U + D
            # the FE truth's own round-off, measured on α and β: what one refinement changes
            # (fᵀψ = −ℓᵀu, so the dual solutions measure it too)
            out = np.concatenate([self.ell @ sol[:, 0], self.f @ sol[:, 1:]])
            change = np.concatenate([self.ell @ D[:, 0], self.f @ D[:, 1:]])
            self.fe_roundoff.extend((np.abs(change) / np.maximum(np.abs(out), 1e-300)).tolist())
        t1 = time.perf_counter()
        new = {}
        for j, s in enumerate(SPACES):
            got = self.spaces[s].orthonormalize(sol[:, j])
            if got is not None:
                new[s] = (*got, np.stack([A @ got[0] for A in self.mats]))
        if new:
            for s, (v, Xv, Av) in new.items():
                self.spaces[s].extend(v, Xv, Av)
            for s, (Z, err) in zip(new, self._region_representers(new), strict=True):
                self.spaces[s].rep.append(Z, err)
            self._extend_cross(new)
        self.snapshots.append(np.asarray(e, dtype=float))
        self.timings_s["fe"] += t1 - t0
        self.timings_s["representers"] += time.perf_counter() - t1

    # ---- the state a finished step adds, for resuming an interrupted build (GreedySteps) ----

    def marks(self) -> dict:
        """Sizes of what grows by appending: per space its basis, orthonormal representers and columns."""
        sizes = {s: (sp_.k, len(sp_.rep.Q), len(sp_.rep.cols)) for s, sp_ in self.spaces.items()}
        return {"spaces": sizes, "snapshots": len(self.snapshots)}

    def step_arrays(self, marks: dict) -> dict[str, np.ndarray]:
        """What the greedy's state gained since ``marks`` (:meth:`marks`), exactly, as arrays.

        Appended columns are given from the mark on; the small arrays that are rebuilt each step
        (reduced matrices, loads, cross terms) whole; the counters and measured accuracies as
        they are now. :meth:`apply_step` on a greedy at ``marks`` gives this state bit for bit.
        """
        out: dict[str, np.ndarray] = {}
        for s in SPACES:
            sp_, (k0, q0, c0) = self.spaces[s], marks["spaces"][s]
            cols = sp_.rep.cols[c0:]
            out |= {
                f"{s}_V": sp_.V.matrix[:, k0:].copy(),
                f"{s}_XV": sp_.XV.matrix[:, k0:].copy(),
                f"{s}_Q": sp_.rep.Q.matrix[:, q0:].copy(),
                f"{s}_XQ": sp_.rep.XQ.matrix[:, q0:].copy(),
                f"{s}_col_sizes": np.array([c.size for c in cols], dtype=np.int64),
                f"{s}_cols": np.concatenate(cols) if cols else np.zeros(0),
                f"{s}_eta": np.array(sp_.rep.eta[c0:], dtype=float),
                f"{s}_A": sp_.A,
                f"{s}_g": sp_.g,
            }
        out |= {f"cross_{d}": self.cross[d] for d in DUALS}
        out["snapshots"] = np.array(self.snapshots[marks["snapshots"] :], dtype=float).reshape(-1, 5)
        out["fe_roundoff"] = np.array(self.fe_roundoff, dtype=float)
        out["accuracy"] = np.array([self.derive_rel, self.xsolve.rel])
        out["counts"] = np.array([self._rep_calls, self.xsolve.calls], dtype=np.int64)
        out["xsolve_norms"] = self.xsolve.norms
        out["timings"] = np.array([self.timings_s["fe"], self.timings_s["representers"]])
        return out

    def apply_step(self, a: dict[str, np.ndarray]) -> None:
        """Take the state :meth:`step_arrays` recorded, on a greedy at that record's marks."""
        for s in SPACES:
            sp_ = self.spaces[s]
            for v, xv in zip(a[f"{s}_V"].T, a[f"{s}_XV"].T, strict=True):
                sp_.V.append(v)
                sp_.XV.append(xv)
            for q, xq in zip(a[f"{s}_Q"].T, a[f"{s}_XQ"].T, strict=True):
                sp_.rep.Q.append(q)
                sp_.rep.XQ.append(xq)
            ends = np.cumsum(a[f"{s}_col_sizes"])
            sp_.rep.cols.extend(np.split(a[f"{s}_cols"], ends[:-1]) if ends.size else [])
            sp_.rep.eta.extend(a[f"{s}_eta"].tolist())
            sp_.A, sp_.g = a[f"{s}_A"], a[f"{s}_g"]
        self.cross = {d: a[f"cross_{d}"] for d in DUALS}
        self.snapshots.extend(np.array(e) for e in a["snapshots"])
        self.fe_roundoff = a["fe_roundoff"].tolist()
        self.derive_rel, self.xsolve.rel = (float(v) for v in a["accuracy"])
        self._rep_calls, self.xsolve.calls = (int(v) for v in a["counts"])
        self.xsolve.norms = a["xsolve_norms"]
        self.timings_s["fe"], self.timings_s["representers"] = (float(v) for v in a["timings"])

    def _region_representers(self, new: dict) -> list[tuple[np.ndarray, np.ndarray]]:
        """X⁻¹A_r v for the six regions of each new basis vector, five solved and one derived.

        X = Σ_r θ̄_r A_r, so Σ_r θ̄_r X⁻¹A_r v = v: the region d of largest energy share
        θ̄_d vᵀA_d v follows from the other five, z_d = (v − Σ_{r≠d} θ̄_r z_r) / θ̄_d, and its
        X-norm error is at most (Σ_{r≠d} θ̄_r err_r) / θ̄_d plus what the identity misses in
        floating point (X's own rounding). That last part is measured like the solver's accuracy
        (:class:`XSolver`): on the first step and every :data:`REFINE_EVERY`-th all six are solved
        and z_d is compared with its derived value; every derived z_d gets 10 × the largest
        relative difference seen (at least 1e-13) × its X-norm. Taking the largest energy share
        keeps the others' errors from being amplified much: θ̄_r‖z_r‖_X ≤ ‖v‖_X (θ̄_r A_r ≤ X)
        and θ̄_d‖z_d‖_X ≥ θ̄_d vᵀA_d v ≥ ‖v‖²_X / 6.
        """
        n_r = len(self.mats)
        full = (
            self._rep_calls % REFINE_EVERY == 0
        )  # the first step and every REFINE_EVERY-th: check the identity
        self._rep_calls += 1
        derive = {s: int(np.argmax(self.theta_bar * (Av @ v))) for s, (v, _, Av) in new.items()}
        blocks = [Av if full else np.delete(Av, derive[s], axis=0) for s, (_, _, Av) in new.items()]
        Z, err = self.xsolve(np.concatenate(blocks).T)
        norms = self.xsolve.norms
        out, at = [], 0
        for s, (v, _, _) in new.items():
            d, w = derive[s], n_r if full else n_r - 1
            Zs, es, ns = Z[:, at : at + w], err[at : at + w], norms[at : at + w]
            at += w
            others = [r for r in range(n_r) if r != d]
            Zo, eo = (Zs[:, others], es[others]) if full else (Zs, es)
            zd = (v - Zo @ self.theta_bar[others]) / self.theta_bar[d]
            if full:
                diff = zd - Zs[:, d]
                dn = float(np.sqrt(max(diff @ (self.X @ diff), 0.0)))
                self.derive_rel = max(self.derive_rel, dn / max(float(ns[d]), 1e-300))
                out.append((Zs, es))
                continue
            znorm = float(np.sqrt(max(zd @ (self.X @ zd), 0.0)))
            ed = (self.theta_bar[others] @ eo) / self.theta_bar[d] + max(10 * self.derive_rel, 1e-13) * znorm
            out.append((np.insert(Zs, d, zd, axis=1), np.insert(es, d, ed)))
        return out

    def _extend_cross(self, new: dict) -> None:
        """Grow Wᵀ A_r V by the new primal column and the new dual rows (no stored A_r V needed)."""
        V = self.spaces["u"].V.matrix
        for d in DUALS:
            W = self.spaces[d].V.matrix
            old = self.cross[d]
            C = np.zeros((len(self.mats), W.shape[1], V.shape[1]))
            C[:, : old.shape[1], : old.shape[2]] = old
            if "u" in new:
                C[:, :, -1] = new["u"][2] @ W
            if d in new:
                C[:, -1, :] = new[d][2] @ V
            self.cross[d] = C

    def arrays(self, orthogonality: bool = False) -> dict[str, np.ndarray]:
        """The online arrays (:mod:`isj.fem.rom.online`) of the current bases."""
        out: dict[str, np.ndarray] = {"theta_bar": self.theta_bar}
        for s in SPACES:
            sp_ = self.spaces[s]
            R, eta = sp_.rep.arrays()
            # the round-off of R c: |fl(Rc) − Rc| ≤ γ_m |R| |c|, and ‖|R||c|‖ ≤ Σ_j |c_j| ‖R_j‖
            eta = eta + (R.shape[1] + 2) * np.finfo(float).eps * np.linalg.norm(R, axis=0)
            # ‖Q R c‖_X ≤ √(1 + ‖QᵀXQ − I‖) ‖R c‖: the cost of Q's last bits of non-orthogonality
            # (measured once, for the stored model: m² n operations)
            scale = 1.0 + 1e-10
            if orthogonality:
                Q = sp_.rep.Q.matrix
                scale = float(np.sqrt(1 + np.linalg.norm(Q.T @ (self.X @ Q) - np.eye(Q.shape[1]))))
            out |= {
                f"{s}_A": sp_.A,
                f"{s}_g": sp_.g,
                f"{s}_R": R,
                f"{s}_eta": eta,
                f"{s}_scale": np.array(scale),
            }
        V = self.spaces["u"].V.matrix
        out["l_u"] = self.ell @ V
        for d in DUALS:
            out[f"{d}_fw"] = self.f @ self.spaces[d].V.matrix
            out[f"{d}_C"] = self.cross[d]
        worst = max(self.fe_roundoff, default=0.0)
        out["floor_rel"] = np.array(max(1e-10, 100 * worst))
        return out


#: Bump when what a greedy step file holds changes meaning.
STEP_FORMAT = 1

#: The arrays of a greedy step file (:meth:`Greedy.step_arrays`, the training set).
STEP_ARRAYS = frozenset(
    [f"{s}_{n}" for s in SPACES for n in ("V", "XV", "Q", "XQ", "col_sizes", "cols", "eta", "A", "g")]
    + [f"cross_{d}" for d in DUALS]
    + ["snapshots", "fe_roundoff", "accuracy", "counts", "xsolve_norms", "timings", "train"]
)


class GreedySteps:
    """The finished steps of one greedy on disk, so that a killed build resumes where it stopped.

    Each step (one FE snapshot and its representers) is one checksummed NPZ entry
    (:mod:`isj.cachefile`), ``<directory>/step-<n>.npz``, written atomically as soon as the step
    is done. It holds what the step added to the greedy's state (:meth:`Greedy.step_arrays`),
    the training set and the history so far, and is keyed three ways so that a stale one is
    never used: the build's cache key (:func:`isj.fem.rom.model.cache_key`, everything the
    surrogate depends on) with :data:`STEP_FORMAT`, the solver backend and the number of
    unknowns, and the checksum of the step before it (a chain: a step whose predecessor was
    rewritten is not taken).

    Parameters
    ----------
    directory : the folder of this build's steps
    key : the build's cache key
    """

    def __init__(self, directory, key: str):
        self.directory, self.key = Path(directory), key
        self.restored = 0  # steps taken from disk by the last restore
        self._prev = ""
        self._marks = None
        self._ident = ""

    def _path(self, n: int):
        return self.directory / f"step-{n:04d}.npz"

    def _identity(self, greedy: Greedy) -> str:
        return canonical_json(
            {
                "key": self.key,
                "format": STEP_FORMAT,
                "solver": type(greedy._xs).__name__,
                "n": int(greedy.X.shape[0]),
            }
        )

    def restore(self, greedy: Greedy) -> tuple[np.ndarray, list] | None:
        """Apply every finished step to a new ``greedy``; (training set, history) of the last, or None.

        A damaged step file is reported (:class:`~isj.errors.CorruptCacheEntry`) and deleted; it
        and every later one are recomputed.
        """
        self._ident = self._identity(greedy)
        self._marks = greedy.marks()
        found, n = None, 1
        while self._path(n).exists():
            path = self._path(n)
            try:
                arrays, digest = read_npz_entry(path)
                meta = json.loads(str(arrays.pop("step_json")))
                if (meta.get("identity"), meta.get("step"), meta.get("prev")) != (self._ident, n, self._prev):
                    raise DamagedEntry("written by another build or after another step")
                if set(arrays) != STEP_ARRAYS:
                    raise DamagedEntry("not the arrays of a greedy step")
                greedy.apply_step(arrays)
            except (DamagedEntry, KeyError, TypeError, ValueError) as exc:
                discard(path, "surrogate greedy step", str(exc), stacklevel=2)
                break
            self._prev, self._marks = digest, greedy.marks()
            found = (arrays["train"], meta["history"])
            n += 1
        for later in sorted(self.directory.glob("step-*.npz")):  # past a break: never usable
            if later.name > self._path(n - 1).name:
                later.unlink(missing_ok=True)
        self.restored = n - 1
        return found

    def save(self, greedy: Greedy, train: np.ndarray, history: list) -> None:
        """Store the step just finished (the greedy's new snapshot), atomically."""
        if self._marks is None:
            self._ident, self._marks = self._identity(greedy), greedy.marks()
        n = len(greedy.snapshots)
        meta = {"identity": self._ident, "step": n, "prev": self._prev, "history": history}
        arrays = greedy.step_arrays(self._marks) | {
            "train": np.asarray(train, dtype=float),
            "step_json": np.array(canonical_json(meta)),
        }
        self._prev = write_npz_entry(self._path(n), arrays)
        self._marks = greedy.marks()

    def clear(self) -> None:
        """Remove the steps (the finished surrogate is stored)."""
        shutil.rmtree(self.directory, ignore_errors=True)


def run_greedy(
    greedy: Greedy,
    train: np.ndarray,
    validate: np.ndarray,
    tol: float,
    safety: float = 0.5,
    margin: float = 0.65,
    max_steps: int = 80,
    progress=None,
    steps: GreedySteps | None = None,
) -> dict:
    """Greedy to ``safety·tol`` on ``train``, then until every ``validate`` design is within ``margin·tol``.

    The margin is for the designs no finite set holds: a surrogate validated at ``tol`` itself
    exceeds ``tol`` on β/α somewhere else in the domain (the measurements: docs/history.md).

    A validation design above ``margin·tol`` joins the training set and the greedy goes on.
    Returns the history: per step the design added and the training set's worst relative bound.

    With ``steps`` each finished step is stored, and the steps a killed run stored are taken
    first: the run goes on from the last one, to the same result bit for bit (every choice
    the greedy makes follows from its state, which the steps restore exactly).
    """
    history = []
    train = np.asarray(train, dtype=float)
    resumed = steps.restore(greedy) if steps is not None else None
    if resumed is not None:
        train, history = resumed
    else:
        greedy.add_snapshot(greedy.space.center())
        if steps is not None:
            steps.save(greedy, train, history)
    while True:
        arr = greedy.arrays()
        rel, _ = relative_bounds(arr, greedy.space.theta(train))
        worst = int(np.argmax(rel))
        top = float(rel[worst])  # infinite while α's interval still holds 0: JSON null
        history.append(
            {"n_snapshots": len(greedy.snapshots), "train_max_rel_bound": top if np.isfinite(top) else None}
        )
        if progress:
            progress(history[-1])
        if rel[worst] > safety * tol and len(greedy.snapshots) < max_steps:
            greedy.add_snapshot(train[worst])
            if steps is not None:
                steps.save(greedy, train, history)
            continue
        vrel, _ = relative_bounds(arr, greedy.space.theta(validate))
        over = np.flatnonzero(vrel > margin * tol)
        history[-1]["validate_max_rel_bound"] = float(vrel.max())
        if over.size == 0 or len(greedy.snapshots) >= max_steps:
            return {
                "history": history,
                "validate_max_rel_bound": float(vrel.max()),
                "converged": bool(over.size == 0),
            }
        train = np.concatenate([train, validate[over[np.argsort(-vrel[over])][:8]]])
