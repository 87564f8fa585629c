"""P1/P2 Lagrange node layout on a linear tetrahedral mesh, and element geometry.

P2 nodes are created here from the linear connectivity (edge midpoints: exact,
the geometry is straight-sided). Because the capsule's free interface is made
by duplicating vertices before this step, its edges are distinct from the bone
side's, and so are their mid-edge nodes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .elements import TET10_EDGES, n_nodes

_TRI6_EDGES = np.array([[0, 1], [1, 2], [0, 2]], dtype=np.int64)


@dataclass(frozen=True)
class Space:
    """Nodes and element geometry of a P1 or P2 discretization.

    Attributes
    ----------
    order : 1 or 2
    points : (n_nodes, 3) node coordinates (m); vertices first, then mid-edge nodes.
    cells : (n_tets, 4 | 10) node ids per element, VTK order.
    region : (n_tets,) region id per element.
    region_names : names indexed by region id.
    faces : name → (n_tri, 3 | 6) node ids of boundary triangles (P2: vertices
        then mid-edge nodes of edges (0,1), (1,2), (0,2), VTK ``triangle6``).
    jac : (n_tets, 3, 3) Jacobian ∂x/∂ξ (m); det : (n_tets,) its determinant (m³);
    inv_jac : (n_tets, 3, 3) its inverse (1/m).
    """

    order: int
    points: np.ndarray
    cells: np.ndarray
    region: np.ndarray
    region_names: tuple[str, ...]
    faces: dict[str, np.ndarray]
    n_vertices: int
    jac: np.ndarray = field(repr=False)
    det: np.ndarray = field(repr=False)
    inv_jac: np.ndarray = field(repr=False)

    @property
    def n_nodes(self) -> int:
        return self.points.shape[0]

    @property
    def n_dofs(self) -> int:
        return 3 * self.n_nodes

    @property
    def n_tets(self) -> int:
        return self.cells.shape[0]

    def region_id(self, name: str) -> int:
        return self.region_names.index(name)

    def face_nodes(self, name: str) -> np.ndarray:
        """Sorted unique node ids on a named face."""
        return np.unique(self.faces[name])


def _edge_keys(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    return lo.astype(np.int64) * n + hi


def build_space(mesh, order: int) -> Space:
    """Lay out P1 or P2 nodes on a linear ``TetMesh``.

    Parameters
    ----------
    mesh : fem.mesh.TetMesh (points in m, positively oriented tets)
    order : 1 or 2
    """
    if order not in (1, 2):
        raise ValueError(f"order = {order!r}: must be 1 or 2")
    pts = np.asarray(mesh.points, dtype=float)
    tets = np.asarray(mesh.tets, dtype=np.int64)
    nv = pts.shape[0]
    faces = {k: np.asarray(v, dtype=np.int64) for k, v in mesh.faces.items()}
    if order == 2:
        keys = _edge_keys(tets[:, TET10_EDGES[:, 0]], tets[:, TET10_EDGES[:, 1]], nv)
        uniq, inv = np.unique(keys.ravel(), return_inverse=True)
        lo, hi = np.divmod(uniq, nv)
        pts = np.vstack([pts, 0.5 * (pts[lo] + pts[hi])])
        cells = np.hstack([tets, nv + inv.reshape(-1, 6)])
        p2faces = {}
        for name, tri in faces.items():
            fk = _edge_keys(tri[:, _TRI6_EDGES[:, 0]], tri[:, _TRI6_EDGES[:, 1]], nv)
            pos = np.searchsorted(uniq, fk)
            if np.any(pos >= uniq.size) or np.any(uniq[np.minimum(pos, uniq.size - 1)] != fk):
                raise ValueError(f"face {name!r} has edges that belong to no tetrahedron")
            p2faces[name] = np.hstack([tri, nv + pos])
        faces = p2faces
    else:
        cells = tets
    x0 = pts[tets[:, 0]]
    jac = np.stack([pts[tets[:, 1]] - x0, pts[tets[:, 2]] - x0, pts[tets[:, 3]] - x0], axis=2)
    det = np.linalg.det(jac)
    if np.any(det <= 0):
        raise ValueError("mesh has inverted or degenerate tetrahedra (det J <= 0)")
    assert cells.shape[1] == n_nodes(order)
    return Space(
        order=order,
        points=pts,
        cells=cells,
        region=np.asarray(mesh.region),
        region_names=tuple(mesh.region_names),
        faces=faces,
        n_vertices=nv,
        jac=jac,
        det=det,
        inv_jac=np.linalg.inv(jac),
    )
