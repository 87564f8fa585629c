"""Online stage: reduced solves, dual-corrected outputs and their bounds, vectorised over designs.

Everything here costs a fixed number of operations per design that depends on the
basis sizes only, never on the FE mesh (docs/rom.md §10.4). The arrays come from
:mod:`isj.fem.rom.offline` (or its cache entry):

- per reduced space ``s`` in ``u`` (primal, load f), ``a`` and ``b`` (duals of α
  and β, load −ℓ): ``{s}_A`` (6, k, k) the region parts of the reduced stiffness,
  ``{s}_g`` (k,) the reduced load, ``{s}_R`` (p, m) the residual's representation
  in an X-orthonormal basis of its Riesz representers, ``{s}_eta`` (m,) the error
  radius of each representer, ``{s}_scale`` the orthonormality guard;
- ``l_u`` (2, k_u): ℓ_α and ℓ_β on the primal basis; per dual ``d``: ``{d}_fw`` (k_d,)
  f on the dual basis and ``{d}_C`` (6, k_d, k_u) the region parts of Wᵀ A_r V;
- ``theta_bar`` (6,) the reference moduli of the energy norm, ``floor_rel`` (scalar)
  the FE truth's own round-off, relative.

Outputs are per unit pressure; :class:`isj.fem.rom.ReducedModel` scales them.
"""

from __future__ import annotations

import numpy as np

#: Designs per block: bounds the memory of the batched reduced matrices (B × k² floats).
CHUNK = 4096

#: Unit round-off of float64.
_EPS = np.finfo(float).eps

SPACES = ("u", "a", "b")
DUALS = ("a", "b")


def coercivity_lb(theta: np.ndarray, theta_bar: np.ndarray) -> np.ndarray:
    """min-θ lower bound of the coercivity constant in the energy norm of ``theta_bar``.

    a(v, v; μ) = Σ_r θ_r a_r(v, v) ≥ min_r (θ_r / θ̄_r) Σ_r θ̄_r a_r(v, v) because every
    a_r is positive semi-definite: rigorous, with no eigenvalue problem solved.
    """
    return np.min(theta / theta_bar, axis=1)


def residual_coefficients(theta: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(B, 1 + 6k) coefficients of the residual g − Σ_r θ_r A_r V x in its representer order.

    Order: the load first, then for each basis vector n the six regions (n-major), as
    :class:`isj.fem.rom.offline.Representers` appends them.
    """
    B, k = x.shape
    c = np.empty((B, 1 + theta.shape[1] * k))
    c[:, 0] = 1.0
    c[:, 1:] = -(x[:, :, None] * theta[:, None, :]).reshape(B, -1)
    return c


def residual_norm(c: np.ndarray, R: np.ndarray, eta: np.ndarray, scale: float) -> np.ndarray:
    """Upper bound of the residual's dual norm ‖r‖_X' for coefficients ``c`` (B, m).

    ‖r‖_X' = ‖Z c‖_X with Z the Riesz representers; Z = Q R with Q X-orthonormal, so it
    is ‖R c‖₂, a sum of terms of the size of the residual itself: accurate at small
    residuals, where expanding cᵀ G c over the representers' Gram matrix G would lose every
    digit to cancellation (docs/rom.md §10.5). Guards: ``scale`` = √(1 + ‖QᵀXQ − I‖) for
    Q's departure from orthonormality, and Σ_j η_j |c_j|, with η_j the error radius of
    representer j (its solve, its orthogonalisation) plus γ_m ‖R_j‖ for the round-off of R c.
    """
    y = c @ R.T
    return scale * np.sqrt(np.einsum("ij,ij->i", y, y)) + np.abs(c) @ eta


def _solve(arr: dict, s: str, theta: np.ndarray) -> np.ndarray:
    """(B, k) reduced solution of space ``s`` (k = 0: an empty array)."""
    A, g = arr[f"{s}_A"], arr[f"{s}_g"]
    k = g.size
    if k == 0:
        return np.zeros((theta.shape[0], 0))
    M = (theta @ A.reshape(A.shape[0], k * k)).reshape(-1, k, k)
    return np.linalg.solve(M, np.broadcast_to(g, (theta.shape[0], k))[:, :, None])[:, :, 0]


def evaluate_unit(arr: dict, theta: np.ndarray) -> dict[str, np.ndarray]:
    """α, β (rad per Pa) with their bounds for region moduli ``theta`` (B, 6), Pa.

    Returns
    -------
    dict
        ``alpha``, ``beta``, ``alpha_bound``, ``beta_bound``, ``alpha_lb`` (coercivity bound),
        ``res_u``, ``res_a``, ``res_b`` (residual dual norms); arrays of shape (B,).
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    out: dict[str, list] = {}
    for start in range(0, theta.shape[0], CHUNK):
        part = _evaluate_block(arr, theta[start : start + CHUNK])
        for key, val in part.items():
            out.setdefault(key, []).append(val)
    return {key: np.concatenate(v) for key, v in out.items()}


def _evaluate_block(arr: dict, theta: np.ndarray) -> dict[str, np.ndarray]:
    x = {s: _solve(arr, s, theta) for s in SPACES}
    res = {
        s: residual_norm(
            residual_coefficients(theta, x[s]), arr[f"{s}_R"], arr[f"{s}_eta"], float(arr[f"{s}_scale"])
        )
        for s in SPACES
    }
    lb = coercivity_lb(theta, arr["theta_bar"])
    out = {"alpha_lb": lb, **{f"res_{s}": res[s] for s in SPACES}}
    xu = x["u"]
    floor = float(arr["floor_rel"])
    for i, (d, name) in enumerate(zip(DUALS, ("alpha", "beta"), strict=True)):
        xd = x[d]
        C = arr[f"{d}_C"]  # (6, k_d, k_u)
        n_r, kd, ku = C.shape
        s = xu @ arr["l_u"][i]
        if kd and ku:
            # s_N = ℓ(u_N) − r_pr(ψ_N) with r_pr(ψ_N) = f(W y) − Σ_r θ_r yᵀ C_r x; the dual solves
            # K ψ = −ℓ, so s − s_N = −a(e, e_du): the product of the two errors
            Cx = (xu @ C.transpose(2, 0, 1).reshape(ku, n_r * kd)).reshape(-1, n_r, kd)
            Cx = np.einsum("br,brk->bk", theta, Cx)  # two two-operand contractions: BLAS-free but
            s = s - xd @ arr[f"{d}_fw"] + np.einsum("bk,bk->b", Cx, xd)  # far faster than one of three
        out[name] = s
        out[f"{name}_bound"] = res["u"] * res[d] / lb + floor * np.abs(s)
    return out


def derived_bounds(a, da, b, db) -> dict[str, np.ndarray]:
    """α + β and β/α with rigorous bounds from those of α and β (interval arithmetic).

    β/α's bound is the larger distance from β/α to the ends of the interval
    [β ∓ Δβ] / [α ± Δα]; infinite where the interval of α contains 0.
    """
    ratio = b / a
    lo_a, hi_a = a - da, a + da
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.stack([(b - db) / lo_a, (b - db) / hi_a, (b + db) / lo_a, (b + db) / hi_a])
        spread = np.max(np.abs(q - ratio), axis=0)
    spread = np.where(lo_a * hi_a > 0, spread, np.inf)
    return {"sum": a + b, "sum_bound": da + db, "ratio": ratio, "ratio_bound": spread}
