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

import time

import numpy as np
import scipy.sparse as sp

from isj.design import REGIONS

from ..assembly import combine, lame_unit
from ..solvers import make_solver
from .domain import DesignSpace
from .online import DUALS, SPACES, derived_bounds, evaluate_unit

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


def relative_bounds(arr: dict, theta: np.ndarray, boxes=None, t=None) -> tuple[np.ndarray, dict]:
    """(B,) the largest relative bound over α, β and β/α, and the evaluation behind it.

    With ``boxes`` (and the designs' unit coordinates ``t``): through the sub-boxes' local arrays.
    """
    if boxes:
        from .local import evaluate_local

        ev = evaluate_local(boxes, t, theta)
    else:
        ev = evaluate_unit(arr, theta)
    der = derived_bounds(ev["alpha"], ev["alpha_bound"], ev["beta"], ev["beta_bound"])
    with np.errstate(divide="ignore", invalid="ignore"):
        ra = ev["alpha_bound"] / np.abs(ev["alpha"])
        rb = ev["beta_bound"] / np.abs(ev["beta"])
        rr = der["ratio_bound"] / np.abs(der["ratio"])
    # where α's interval holds 0 the ratio's bound is infinite; rank by ra + rb there, so that
    # the greedy still goes for the worst design instead of the first infinite one
    rr = np.where(np.isfinite(rr), rr, ra + rb)
    rel = np.nan_to_num(np.maximum(np.maximum(ra, rb), rr), nan=np.inf, posinf=np.inf)
    return rel, ev


def run_greedy(
    greedy: Greedy,
    train: np.ndarray,
    validate: np.ndarray,
    tol: float,
    safety: float = 0.5,
    margin: float = 0.65,
    max_steps: int = 80,
    progress=None,
) -> dict:
    """Greedy to ``safety·tol`` on ``train``, then until every ``validate`` design is within ``margin·tol``.

    The margin is for the designs no finite set holds: on the default mesh, validating at
    ``tol`` itself left 1.07e-3 on β/α somewhere in a fresh sample of 1e6 designs, and at
    0.8 ``tol`` 1.01e-3.

    A validation design above ``margin·tol`` joins the training set and the greedy goes on.
    Returns the history: per step the design added and the training set's worst relative bound.
    """
    history = []
    train = np.asarray(train, dtype=float)
    greedy.add_snapshot(greedy.space.center())
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
