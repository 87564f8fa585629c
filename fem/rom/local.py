"""Local bases: the global reduced spaces compressed per sub-box of the domain (docs/rom.md §10.6).

The greedy's bases (about 31 vectors per space on the default mesh) are what the worst
designs of the whole domain need; a design in one half of every modulus range needs far
fewer directions of them. The domain is cut into 2⁵ = 32 sub-boxes (each log-range halved)
and, per sub-box and space, the global basis is rotated and truncated to the leading POD
directions Φ (k × k_l) of the reduced solutions at sample designs of that sub-box. The
local space V Φ lies in the global one, so every online array follows from the global
arrays with no FE-sized work, and the bound stays rigorous for the solution it is given:

- the residual's representers of V Φ are those of V combined by Φ (R_l = R Φ, per region);
- their error radii by the triangle inequality: η_l[n', r] = Σ_n η[n, r] |Φ[n, n']|, plus
  the round-off of forming R_l;
- R_l is compressed by a QR factorization to its triangular factor T (‖R_l c‖ = ‖T c‖ for an
  orthonormal Q), plus a guard for the factorization's own round-off.

The local size is the smallest that keeps every sample design of the sub-box (and its 32
corners) within ``target · tol``; where none does, the sub-box keeps the global basis.
Cost per design: the reduced solves scale with k_l³, the residuals with k_l².
"""

from __future__ import annotations

import numpy as np

from .online import DUALS, SPACES, _solve, derived_bounds, evaluate_unit

#: Parts per ranged modulus: 2 → 2⁵ = 32 sub-boxes.
SPLIT = 2

#: Sample designs per sub-box that choose and check its local size.
N_SAMPLE = 512

_EPS = np.finfo(float).eps


def box_index(t: np.ndarray) -> np.ndarray:
    """(n,) sub-box of unit-cube points ``t`` (n, d): Σ_j ⌊SPLIT t_j⌋ SPLITʲ (the face t = 1 inside)."""
    b = np.clip(np.floor(np.asarray(t, dtype=float) * SPLIT), 0, SPLIT - 1).astype(np.int64)
    return b @ (SPLIT ** np.arange(b.shape[1]))


def box_sample(space, box: int, n: int, seed: int) -> np.ndarray:
    """(n + 2^d, d) moduli (Pa): ``n`` scrambled Sobol designs of sub-box ``box`` and its corners."""
    from scipy.stats import qmc

    d = len(space.log_lo)
    lo = (box // SPLIT ** np.arange(d)) % SPLIT
    m = max(1, int(np.ceil(np.log2(max(n, 1)))))
    t = qmc.Sobol(d, scramble=True, seed=seed + box).random_base2(m)[:n]
    corners = (np.arange(2**d)[:, None] >> np.arange(d)) & 1
    return space.from_unit((lo + np.concatenate([t, corners])) / SPLIT)


def compress(arr: dict, phi: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The online arrays of the local spaces V Φ_s, Φ_s (k_s × l_s) with orthonormal columns."""
    out = {"theta_bar": arr["theta_bar"], "floor_rel": arr["floor_rel"]}
    for s in SPACES:
        P = phi[s]
        k = P.shape[0]
        A = arr[f"{s}_A"]
        R, eta = arr[f"{s}_R"], arr[f"{s}_eta"]
        n_r = A.shape[0]
        Rr = R[:, 1:].reshape(R.shape[0], k, n_r)  # representer order: basis vector major, region minor
        Rl = np.column_stack([R[:, 0], np.einsum("pnr,nm->pmr", Rr, P).reshape(R.shape[0], -1)])
        absP = np.abs(P)
        # error radii through Φ (triangle inequality), plus the round-off of R Φ: γ_k |R| |Φ|
        eta_l = np.einsum("nr,nm->mr", eta[1:].reshape(k, n_r), absP).reshape(-1)
        form = np.linalg.norm(np.einsum("pnr,nm->pmr", np.abs(Rr), absP), axis=0).reshape(-1)
        eta_l = np.concatenate([[eta[0]], eta_l + (k + 2) * _EPS * form])
        # ‖R_l c‖ = ‖T c‖ with R_l = Q T. Householder QR is backward stable: the computed T is
        # exactly that of R_l + δ with ‖δ_j‖ ≤ γ̃_{pm} ‖R_l,j‖ (Higham, Accuracy and Stability of
        # Numerical Algorithms, 2nd ed., Thm 19.4); the guard takes 10 p m ε for γ̃_{pm}, and
        # adds the online round-off of T c, (m + 2) ε ‖T_j‖, as the global arrays do
        T = np.linalg.qr(Rl, mode="r")
        p_, m_ = Rl.shape
        eta_l = eta_l + 10 * p_ * m_ * _EPS * np.linalg.norm(Rl, axis=0)
        eta_l = eta_l + (m_ + 2) * _EPS * np.linalg.norm(T, axis=0)
        out |= {
            f"{s}_A": np.einsum("ni,rnm,mj->rij", P, A, P),
            f"{s}_g": P.T @ arr[f"{s}_g"],
            f"{s}_R": np.ascontiguousarray(T),
            f"{s}_eta": eta_l,
            f"{s}_scale": arr[f"{s}_scale"],
        }
    out["l_u"] = arr["l_u"] @ phi["u"]
    for d in DUALS:
        out[f"{d}_fw"] = phi[d].T @ arr[f"{d}_fw"]
        out[f"{d}_C"] = np.einsum("ni,rnm,mj->rij", phi[d], arr[f"{d}_C"], phi["u"])
    return out


def local_bases(
    arr: dict, space, tol: float, target: float = 0.7, seed: int = 0
) -> tuple[list[dict], list[int]]:
    """Per sub-box: the compressed online arrays and the local size (bisection on the sample).

    A sub-box whose sample needs the whole global basis keeps the global arrays as they are.
    The sub-boxes are independent: they run on :func:`fem.solvers.solver_threads` threads, and a
    sub-box's arrays do not depend on which thread computed it (each runs the same arithmetic;
    callers hold numpy's BLAS to one thread, :func:`fem.ear.joint_condensation.one_blas_thread`).
    """
    from ..solvers import on_solver_threads

    n_boxes = SPLIT ** len(space.log_lo)
    done = on_solver_threads(lambda box: _local_box(arr, space, box, tol, target, seed), range(n_boxes))
    return [b for b, _ in done], [size for _, size in done]


def _local_box(arr: dict, space, box: int, tol: float, target: float, seed: int) -> tuple[dict, int]:
    """One sub-box's compressed arrays and local size: the smallest whose sample designs all keep
    their bound within ``target · tol`` (the global arrays and size where none does)."""
    k = int(arr["u_g"].size)
    theta = space.theta(box_sample(space, box, N_SAMPLE, seed))
    basis = {}
    for s in SPACES:
        x = _solve(arr, s, theta)
        basis[s] = np.linalg.svd(x.T, full_matrices=False)[0]  # POD directions, k × min(k, n)
    lo, hi = 1, k  # hi: the global basis, taken as passing
    best = None
    while lo < hi:
        mid = (lo + hi) // 2
        trial = compress(arr, {s: basis[s][:, :mid] for s in SPACES})
        if relative_bounds(trial, theta)[0].max() <= target * tol:
            hi, best = mid, trial
        else:
            lo = mid + 1
    if best is None or hi >= k:
        best, hi = {key: arr[key] for key in _keys(arr)}, k
    return best, hi


def _keys(arr: dict) -> list[str]:
    """The keys of the online arrays (the greedy's ``arrays()``, without extra entries)."""
    keys = ["theta_bar", "floor_rel", "l_u"]
    keys += [f"{s}_{n}" for s in SPACES for n in ("A", "g", "R", "eta", "scale")]
    keys += [f"{d}_{n}" for d in DUALS for n in ("fw", "C")]
    return [key for key in keys if key in arr]


def pack(boxes: list[dict]) -> dict[str, np.ndarray]:
    """Flat NPZ entries ``box<i>_<key>`` of the sub-boxes' arrays."""
    return {f"box{i}_{key}": val for i, b in enumerate(boxes) for key, val in b.items()}


def unpack(arrays: dict) -> list[dict]:
    """The sub-boxes' arrays from :func:`pack`'s entries (empty if there are none)."""
    boxes: dict[int, dict] = {}
    for name, val in arrays.items():
        if name.startswith("box"):
            i, key = name[3:].split("_", 1)
            boxes.setdefault(int(i), {})[key] = val
    return [boxes[i] for i in sorted(boxes)]


def evaluate_local(boxes: list[dict], t: np.ndarray, theta: np.ndarray) -> dict[str, np.ndarray]:
    """:func:`evaluate_unit` with each design in its sub-box's arrays (``t`` its unit coordinates)."""
    idx = box_index(t)
    order = np.argsort(idx, kind="stable")
    edges = np.searchsorted(idx[order], np.arange(len(boxes) + 1))
    out: dict[str, np.ndarray] = {}
    for b in range(len(boxes)):
        sel = order[edges[b] : edges[b + 1]]
        if sel.size == 0:
            continue
        part = evaluate_unit(boxes[b], theta[sel])
        for key, val in part.items():
            if key not in out:
                out[key] = np.empty(theta.shape[0])
            out[key][sel] = val
    return out


def relative_bounds(arr: dict, theta: np.ndarray, boxes=None, t=None) -> tuple[np.ndarray, dict]:
    """(B,) the largest relative bound over α, β and β/α, and the evaluation behind it.

    With ``boxes`` (and the designs' unit coordinates ``t``): through the sub-boxes' local arrays.
    """
    if boxes:
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
