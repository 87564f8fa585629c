"""Lagrange tetrahedra (P1, P2) on the reference tetrahedron, and quadrature.

Reference tetrahedron: vertices (0,0,0), (1,0,0), (0,1,0), (0,0,1) with
barycentric coordinates L0 = 1 − ξ − η − ζ, L1 = ξ, L2 = η, L3 = ζ.

P2 node order is VTK's ``tetra10`` (and meshio's): the four vertices, then the
mid-edge nodes of edges (0,1), (1,2), (0,2), (0,3), (1,3), (2,3). Keeping that
order lets displacement fields go to ParaView without reordering.
"""

from __future__ import annotations

from functools import cache

import numpy as np

#: Vertex pairs of the P2 mid-edge nodes, in VTK tetra10 order.
TET10_EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]], dtype=np.int64)

#: Gradient of the barycentric coordinates with respect to (ξ, η, ζ).
_DL = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


@cache
def tet_quadrature(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Stroud conical-product rule on the reference tetrahedron.

    Gauss–Jacobi points in collapsed coordinates, ``n`` per direction
    (``n**3`` points), exact for polynomials of total degree ``2n − 1``.
    Weights sum to the reference volume 1/6.

    Returns
    -------
    points : (n**3, 3) reference coordinates; weights : (n**3,)
    """
    # imported here: scipy.special costs 0.15–0.2 s of every CLI start, and the
    # static solve never needs this rule (docs/performance.md §8.2)
    from scipy.special import roots_jacobi

    # ∫_0^1 f(t) (1 − t)^a dt = 2^-(a+1) Σ w_i f((1 + x_i)/2) with Jacobi(a, 0) nodes x_i
    rules = []
    for a in (2, 1, 0):
        x, w = roots_jacobi(n, a, 0)
        rules.append(((1 + x) / 2, w / 2 ** (a + 1)))
    (u, wu), (v, wv), (s, ws) = rules
    U, V, S = np.meshgrid(u, v, s, indexing="ij")
    W = np.einsum("i,j,k->ijk", wu, wv, ws)
    xi = U
    eta = V * (1 - U)
    zeta = S * (1 - U) * (1 - V)
    pts = np.stack([xi.ravel(), eta.ravel(), zeta.ravel()], axis=1)
    return pts, W.ravel()


def barycentric(ref_points: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (…, 4) of reference points (…, 3)."""
    ref_points = np.asarray(ref_points, dtype=float)
    return np.concatenate([1 - ref_points.sum(axis=-1, keepdims=True), ref_points], axis=-1)


def shape_functions(order: int, lam: np.ndarray) -> np.ndarray:
    """Shape-function values (…, n_nodes) at barycentric coordinates ``lam`` (…, 4)."""
    if order == 1:
        return np.array(lam, dtype=float)
    if order == 2:
        vert = lam * (2 * lam - 1)
        edge = 4 * lam[..., TET10_EDGES[:, 0]] * lam[..., TET10_EDGES[:, 1]]
        return np.concatenate([vert, edge], axis=-1)
    raise ValueError(f"order = {order!r}: must be 1 or 2")


def shape_gradients(order: int, lam: np.ndarray) -> np.ndarray:
    """Reference gradients (…, n_nodes, 3) of the shape functions at ``lam`` (…, 4)."""
    lam = np.asarray(lam, dtype=float)
    if order == 1:
        return np.broadcast_to(_DL, lam.shape[:-1] + (4, 3)).copy()
    if order == 2:
        vert = (4 * lam - 1)[..., :, None] * _DL
        a, b = TET10_EDGES[:, 0], TET10_EDGES[:, 1]
        edge = 4 * (lam[..., a, None] * _DL[b] + lam[..., b, None] * _DL[a])
        return np.concatenate([vert, edge], axis=-2)
    raise ValueError(f"order = {order!r}: must be 1 or 2")


def n_nodes(order: int) -> int:
    """Nodes per tetrahedron: 4 (P1) or 10 (P2)."""
    return {1: 4, 2: 10}[order]


@cache
def reference_gradient_products(order: int) -> np.ndarray:
    """S[i, j, a, b] = ∫_ref ∂N_i/∂ξ_a ∂N_j/∂ξ_b dξ, exact (integrand degree ≤ 2)."""
    pts, w = tet_quadrature(2)
    g = shape_gradients(order, barycentric(pts))
    return np.einsum("q,qia,qjb->ijab", w, g, g)


@cache
def reference_mass(order: int) -> np.ndarray:
    """m[i, j] = ∫_ref N_i N_j dξ, exact (integrand degree ≤ 4)."""
    pts, w = tet_quadrature(3)
    n = shape_functions(order, barycentric(pts))
    return np.einsum("q,qi,qj->ij", w, n, n)
