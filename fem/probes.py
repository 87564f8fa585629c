"""Linear functionals of the displacement: point values and rigid rotations of bodies.

Each is a sparse matrix acting on the full dof vector (dof = 3·node +
component), built once per mesh, so that α and β of any load case cost a
sparse matrix–vector product.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from isj.errors import PointOutsideBody

from .elements import barycentric, shape_functions, tet_quadrature
from .space import Space


def _locate(space: Space, point: np.ndarray, elems: np.ndarray) -> tuple[int, np.ndarray]:
    """Element of ``elems`` containing ``point`` and the point's barycentric coordinates."""
    x0 = space.points[space.cells[elems, 0]]
    ref = np.einsum("eak,ek->ea", space.inv_jac[elems], point[None, :] - x0)
    lam = barycentric(ref)
    best = int(np.argmax(lam.min(axis=1)))
    if lam[best].min() < -1e-8:
        raise PointOutsideBody(f"point {point.tolist()} m lies outside the body")
    return int(elems[best]), np.clip(lam[best], 0.0, 1.0)


def point_operator(space: Space, points_m, region: str) -> sp.csr_matrix:
    """(3·n_points, n_dofs) matrix giving u_x, u_y, u_z at each point of a region.

    Uses the element's own shape functions: the points need not be nodes. On a
    face shared by two elements of the region either element gives the same
    value (continuity).
    """
    pts = np.atleast_2d(np.asarray(points_m, dtype=float))
    elems = np.flatnonzero(space.region == space.region_id(region))
    rows, cols, vals = [], [], []
    for p_idx, p in enumerate(pts):  # a handful of probe points, not elements
        e, lam = _locate(space, p, elems)
        n = shape_functions(space.order, lam)
        nodes = space.cells[e]
        for c in range(3):
            rows.append(np.full(nodes.size, 3 * p_idx + c))
            cols.append(3 * nodes + c)
            vals.append(n)
    return sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(3 * len(pts), space.n_dofs),
    )


def rotation_operator(space: Space, region: str) -> np.ndarray:
    """(3, n_dofs) matrix giving the least-squares rigid rotation ω (rad) of a body.

    Minimises ∫_body |u − t − ω × (x − x̄)|² dV over t and ω; with x̄ the
    centroid, ω = A⁻¹ ∫ r × u dV, A = ∫ (|r|² I − r rᵀ) dV, r = x − x̄. The
    quadrature (degree 3) is exact for P2 displacements on straight tetrahedra.
    """
    elems = np.flatnonzero(space.region == space.region_id(region))
    qp, qw = tet_quadrature(2)
    lam = barycentric(qp)
    N = shape_functions(space.order, lam)  # (q, n)
    x0 = space.points[space.cells[elems, 0]]
    xq = x0[:, None, :] + np.einsum("eak,qk->eqa", space.jac[elems], qp)  # (e, q, 3)
    wdet = space.det[elems][:, None] * qw[None, :]  # (e, q)
    vol = wdet.sum()
    xbar = np.einsum("eq,eqa->a", wdet, xq) / vol
    r = xq - xbar
    A = np.einsum("eq,eqb,eqb->", wdet, r, r) * np.eye(3) - np.einsum("eq,eqa,eqb->ab", wdet, r, r)
    # ∫ (r × u)_a = Σ ε_abc ∫ r_b N_i u_ic: coefficient of dof (i, c) in row a
    eps = np.zeros((3, 3, 3))
    eps[0, 1, 2] = eps[1, 2, 0] = eps[2, 0, 1] = 1
    eps[0, 2, 1] = eps[2, 1, 0] = eps[1, 0, 2] = -1
    rn = np.einsum("eq,eqb,qi->eib", wdet, r, N)  # (e, i, b)
    coef = np.einsum("abc,eib->eaic", eps, rn)  # (e, a, i, c)
    dofs = 3 * space.cells[elems][:, None, :, None] + np.arange(3)[None, None, None, :]
    out = np.zeros((3, space.n_dofs))
    for a in range(3):
        out[a] = np.bincount(
            np.broadcast_to(dofs, coef.shape)[:, a].ravel(),
            weights=coef[:, a].ravel(),
            minlength=space.n_dofs,
        )
    return np.linalg.solve(A, out)
