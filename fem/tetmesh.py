"""The tetrahedral mesh type of the FE model: arrays, regions, named faces and a content hash.

Its own module so that the mesh cache (:mod:`fem.cache`) and the mesher (:mod:`fem.mesh`)
both import it, and neither imports the other back.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class TetMesh:
    """A linear tetrahedral mesh with regions and named boundary faces.

    Attributes
    ----------
    points : ndarray, shape (n_nodes, 3), float64
        Node coordinates (m).
    tets : ndarray, shape (n_tets, 4), int64
        Node indices of each tetrahedron, positively oriented
        (det[p1 − p0, p2 − p0, p3 − p0] > 0).
    region : ndarray, shape (n_tets,), int8
        Region id of each tetrahedron, an index into ``region_names``.
    region_names : tuple of str
        :data:`isj.design.REGIONS` for the joint model, ``("pedicle",)`` for the
        cantilever.
    faces : dict of str to ndarray, shape (n_tri, 3), int64
        Named boundary triangles: ``"clamped"``, ``"loaded"`` and, for the joint
        model, ``"capsule_free"`` (whose triangles use the bone-side node ids).
        Node order makes (p1 − p0) × (p2 − p0) the outward normal; on
        ``"capsule_free"`` it points out of the bone, into the capsule.
    """

    points: np.ndarray
    tets: np.ndarray
    region: np.ndarray
    region_names: tuple[str, ...]
    faces: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_tets(self) -> int:
        return int(self.tets.shape[0])

    def region_id(self, name: str) -> int:
        """Region id of ``name`` (raises ValueError if absent)."""
        return self.region_names.index(name)

    def region_tets(self, name: str) -> np.ndarray:
        """The tetrahedra (n, 4) of region ``name``."""
        return self.tets[self.region == self.region_id(name)]

    def content_hash(self) -> str:
        """sha256 (hex) over the arrays' dtypes, shapes and bytes and all names."""
        h = hashlib.sha256()

        def add(tag: str, a: np.ndarray) -> None:
            a = np.ascontiguousarray(a)
            h.update(f"{tag}|{a.dtype.str}|{a.shape}|".encode())
            h.update(a.tobytes())

        add("points", self.points)
        add("tets", self.tets)
        add("region", self.region)
        h.update(("names|" + "\x1f".join(self.region_names)).encode())
        for name in sorted(self.faces):
            add(f"face:{name}", self.faces[name])
        return h.hexdigest()
