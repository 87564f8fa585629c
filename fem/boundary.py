"""Loads on named faces and clamping of named faces.

Clamping removes the face's dofs from the system; :class:`Reduction` maps the
shared CSR pattern to the pattern of the free-free block once, so that each new
matrix costs one gather of its data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .assembly import Pattern
from .space import Space


def face_areas(space: Space, name: str) -> np.ndarray:
    """Areas (m²) of the triangles of a named face."""
    tri = space.faces[name][:, :3]
    p = space.points
    return 0.5 * np.linalg.norm(np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]), axis=1)


def traction_load(space: Space, name: str, traction_pa) -> np.ndarray:
    """Consistent nodal forces (N) of a uniform traction vector (Pa) on a named face.

    P1 triangles give A/3 to each vertex; P2 (6-node) triangles give nothing to
    the vertices and A/3 to each mid-edge node (∫ of the shape functions).
    """
    t = np.asarray(traction_pa, dtype=float)
    area = face_areas(space, name)
    tri = space.faces[name]
    carriers = tri[:, :3] if space.order == 1 else tri[:, 3:6]
    w = np.bincount(carriers.ravel(), weights=np.repeat(area / 3, 3), minlength=space.n_nodes)
    return (w[:, None] * t[None, :]).ravel()


def pressure_load(space: Space, name: str, pressure_pa: float, direction) -> np.ndarray:
    """Nodal forces (N) of a uniform pressure (Pa) pushing along unit ``direction``."""
    d = np.asarray(direction, dtype=float)
    return traction_load(space, name, pressure_pa * d / np.linalg.norm(d))


def clamped_dofs(space: Space, name: str) -> np.ndarray:
    """All three dofs of every node on a named face (sorted)."""
    nodes = space.face_nodes(name)
    return (3 * nodes[:, None] + np.arange(3)).ravel()


@dataclass(frozen=True)
class Reduction:
    """The free-free block of matrices on a shared pattern, dofs ``fixed`` removed."""

    free: np.ndarray
    keep: np.ndarray  # positions in the full data that survive
    indptr: np.ndarray
    indices: np.ndarray
    n_dofs: int

    @classmethod
    def build(cls, pattern: Pattern, fixed: np.ndarray) -> Reduction:
        n = pattern.n_dofs
        is_free = np.ones(n, dtype=bool)
        is_free[fixed] = False
        free = np.flatnonzero(is_free)
        new_id = np.full(n, -1, dtype=np.int64)
        new_id[free] = np.arange(free.size)
        # an entry survives if its row and its column are free; rows counted by a running
        # sum, not from a row index per entry (three times faster, docs/performance.md §8.2)
        keep = np.repeat(is_free, np.diff(pattern.indptr))
        keep &= is_free[pattern.indices]
        kept_before = np.concatenate([[0], np.cumsum(keep)])
        per_row = kept_before[pattern.indptr[1:]] - kept_before[pattern.indptr[:-1]]
        keep = np.flatnonzero(keep)
        return cls(
            free=free,
            keep=keep,
            indptr=np.concatenate([[0], np.cumsum(per_row[free])]),
            indices=new_id[pattern.indices[keep]],
            n_dofs=n,
        )

    @property
    def n_free(self) -> int:
        return self.free.size

    def matrix(self, data: np.ndarray, dtype=np.float64) -> sp.csr_matrix:
        """Free-free block of the matrix with full-pattern ``data``."""
        return sp.csr_matrix(
            (np.asarray(data[self.keep], dtype=dtype), self.indices, self.indptr),
            shape=(self.n_free, self.n_free),
        )

    def restrict(self, f: np.ndarray) -> np.ndarray:
        return f[self.free]

    def expand(self, u_free: np.ndarray) -> np.ndarray:
        """Full dof vector(s), zero on the clamped dofs."""
        u = np.zeros((self.n_dofs,) + u_free.shape[1:], dtype=u_free.dtype)
        u[self.free] = u_free
        return u
