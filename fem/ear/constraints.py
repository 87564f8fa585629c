"""Dof numbering, clamping, static solves and rigid links for 6-dof shell meshes.

Global dof ``6 i + c`` is component ``c`` of node ``i``, c = 0..5 for
(ux, uy, uz, θx, θy, θz), as in :mod:`fem.ear.shell`. SI units: m, rad, N, N·m.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from isj.errors import InvalidParameter

from .shell import NDOF

#: Component indices by name.
UX, UY, UZ, RX, RY, RZ = range(NDOF)
#: All six components: clamping.
ALL = (UX, UY, UZ, RX, RY, RZ)


def node_dofs(nodes, components=ALL) -> np.ndarray:
    """Global dof indices (sorted, unique) of the given components of the given nodes."""
    nodes = np.asarray(nodes, dtype=np.int64).ravel()
    comps = np.asarray(components, dtype=np.int64).ravel()
    if comps.size and (comps.min() < 0 or comps.max() >= NDOF):
        raise InvalidParameter(f"components = {components!r}: each must lie in [0, {NDOF - 1}]")
    return np.unique((NDOF * nodes[:, None] + comps[None, :]).ravel())


def solve_static(K, f, fixed_dofs, prescribed=None):
    """Solve K u = f with some dofs prescribed (zero unless ``prescribed`` says otherwise).

    Parameters
    ----------
    K : (n, n) sparse stiffness (SI)
    f : (n,) nodal loads (N, N·m)
    fixed_dofs : indices of the constrained dofs
    prescribed : (len(fixed_dofs),) their values (m, rad), default zero

    Returns
    -------
    u : (n,) displacements and rotations (m, rad)
    reactions : (n,) K u − f: the constraint forces, zero on free dofs up to round-off (N, N·m)
    """
    K = sp.csr_matrix(K)
    f = np.asarray(f, dtype=float)
    n = K.shape[0]
    fixed = np.unique(np.asarray(fixed_dofs, dtype=np.int64))
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        raise InvalidParameter(f"fixed_dofs: indices must lie in [0, {n - 1}]")
    u = np.zeros(n)
    if prescribed is not None:
        u[np.asarray(fixed_dofs, dtype=np.int64)] = np.asarray(prescribed, dtype=float)
    free = np.setdiff1d(np.arange(n), fixed)
    rhs = f[free] - K[free][:, fixed] @ u[fixed]
    u[free] = _spd_solve(K[free][:, free], rhs)
    if not np.all(np.isfinite(u)):
        raise np.linalg.LinAlgError("shell stiffness is singular: add supports")
    return u, K @ u - f


def _spd_solve(A, b):
    """Solve with the project's SPD backend when a fast one is installed, else SuperLU (COLAMD)."""
    from isj.fem.solvers import available_backends, make_solver

    fast = [name for name in available_backends() if name != "superlu"]
    if not fast:
        # spsolve's default COLAMD ordering; SuperLU's MMD_AT_PLUS_A was far slower on shell meshes.
        return spla.spsolve(A.tocsc(), b)
    solver = make_solver(A, fast[0])
    solver.factor(sp.csr_matrix(A))
    return solver.solve(b)


def rigid_body_modes(nodes_m, center_m=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The six rigid-body motions of a 6-dof node set, (6N, 6).

    Columns: unit translations along x, y, z, then unit rotations (rad) about
    axes through ``center_m`` along x, y, z: u = θ × (x − center), rotation dofs = θ.
    """
    x = np.asarray(nodes_m, dtype=float) - np.asarray(center_m, dtype=float)
    n = len(x)
    R = np.zeros((n, NDOF, 6))
    for c in range(3):
        R[:, c, c] = 1.0
        R[:, 3 + c, 3 + c] = 1.0
    # Columns of the cross-product matrix: e_k × r.
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        R[:, :3, 3 + k] = np.cross(e, x)
    return R.reshape(n * NDOF, 6)


def rigid_link_transform(nodes_m, slave_nodes, master_point_m) -> tuple[sp.csr_matrix, np.ndarray]:
    """Tie a node set rigidly to a master point with six dofs (master–slave elimination).

    The slaves' dofs become u_s = u_0 + θ_0 × (x_s − x_0), θ_s = θ_0: for example
    the eardrum's manubrium nodes moving with the malleus.

    Parameters
    ----------
    nodes_m : (N, 3) node coordinates (m)
    slave_nodes : indices of the tied nodes
    master_point_m : (3,) position of the master (m)

    Returns
    -------
    T : (6N, n_kept + 6) sparse map from reduced dofs to all dofs, u = T q; the
        last six reduced dofs are the master's (ux, uy, uz, θx, θy, θz)
    kept : (n_kept,) global indices of the dofs that stay independent, in order.
        Reduce with ``T.T @ K @ T`` and ``T.T @ f``.
    """
    x = np.asarray(nodes_m, dtype=float)
    slaves = np.unique(np.asarray(slave_nodes, dtype=np.int64))
    if slaves.size == 0 or slaves.min() < 0 or slaves.max() >= len(x):
        raise InvalidParameter(f"slave_nodes: must be a non-empty set of indices in [0, {len(x) - 1}]")
    n = NDOF * len(x)
    slave_dofs = node_dofs(slaves)
    kept = np.setdiff1d(np.arange(n), slave_dofs)
    link = rigid_body_modes(x[slaves], master_point_m)  # (6 n_s, 6)
    rows = np.concatenate([kept, np.repeat(slave_dofs, 6)])
    cols = np.concatenate([np.arange(kept.size), np.tile(kept.size + np.arange(6), slave_dofs.size)])
    vals = np.concatenate([np.ones(kept.size), link.ravel()])
    keep = vals != 0.0
    T = sp.coo_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, kept.size + 6)).tocsr()
    return T, kept
