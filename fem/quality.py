"""Mesh quality and matrix bandwidth (docs/model.md §2.6, thesis §6.5).

Quality measures, per tetrahedron, vectorised over all elements:

- dihedral angles: the angle between the two faces meeting at each of the six
  edges (rad). A regular tetrahedron has all six equal to arccos(1/3) ≈ 70.53°;
  slivers and needles have some near 0 (or near π).
- aspect ratio: ``R / (3 r)`` with R the circumradius and r the inradius
  (both m). It is 1 for the regular tetrahedron, > 1 otherwise, and → ∞ as the
  element degenerates (gmsh's and many papers' "radius ratio" is its inverse
  3 r / R ∈ (0, 1]).

Bandwidth of a sparse matrix A is max |i − j| over its stored non-zeros;
:func:`rcm_bandwidth` compares it before and after reverse Cuthill–McKee.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

if TYPE_CHECKING:
    from .mesh import TetMesh

#: Local vertex pairs of the six edges; edge k = (i, j) lies between the faces
#: opposite its two other vertices.
_EDGES = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
_OPPOSITE = np.array([(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)])
#: Face f is opposite vertex f; its vertices in order.
_FACES = np.array([(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)])


def tet_quality(points: np.ndarray, tets: np.ndarray) -> dict[str, np.ndarray]:
    """Per-element volume, minimum and maximum dihedral angle, and aspect ratio.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
        Node coordinates (m).
    tets : ndarray, shape (n_tets, 4)
        Node indices.

    Returns
    -------
    dict
        ``"volume"`` (m³, signed: > 0 for positive orientation),
        ``"min_dihedral"``, ``"max_dihedral"`` (rad), ``"aspect_ratio"``
        (R / 3r, dimensionless; inf for a degenerate element), each shape (n_tets,).
    """
    p = np.asarray(points, dtype=np.float64)[np.asarray(tets)]  # (n, 4, 3)
    e1, e2, e3 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    volume = np.einsum("ij,ij->i", np.cross(e1, e2), e3) / 6.0

    # Face normals (area-weighted, orientation-independent use below).
    a, b, c = (p[:, _FACES[:, k]] for k in range(3))  # each (n, 4, 3)
    normals = np.cross(b - a, c - a)  # (n, 4, 3), |normal| = 2·area
    areas2 = np.linalg.norm(normals, axis=2)
    # Orient every normal outwards: away from the opposite vertex.
    centroid = p.mean(axis=1, keepdims=True)
    sign = np.sign(np.einsum("nfk,nfk->nf", normals, a - centroid))
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = normals * (sign / areas2)[:, :, None]
        # Interior dihedral angle at an edge = π − angle between outward normals.
        cosang = -np.einsum("nek,nek->ne", unit[:, _OPPOSITE[:, 0]], unit[:, _OPPOSITE[:, 1]])
        dihedral = np.arccos(np.clip(cosang, -1.0, 1.0))

        # Inradius r = 3V / total area; circumradius from the edge-length products
        # of opposite edge pairs: R = sqrt(∏ (±aA ± bB ± cC)) / (24 V).
        v = np.abs(volume)
        r_in = 3.0 * v / (0.5 * areas2.sum(axis=1))
        length = np.linalg.norm(p[:, _EDGES[:, 1]] - p[:, _EDGES[:, 0]], axis=2)
        # Products of opposite edge lengths: (01, 23), (02, 13), (03, 12).
        aA = length[:, 0] * length[:, 5]
        bB = length[:, 1] * length[:, 4]
        cC = length[:, 2] * length[:, 3]
        prod = (aA + bB + cC) * (aA + bB - cC) * (aA - bB + cC) * (-aA + bB + cC)
        r_circ = np.sqrt(np.maximum(prod, 0.0)) / (24.0 * v)
        aspect = r_circ / (3.0 * r_in)
    aspect = np.where(v > 0, aspect, np.inf)
    return {
        "volume": volume,
        "min_dihedral": dihedral.min(axis=1),
        "max_dihedral": dihedral.max(axis=1),
        "aspect_ratio": aspect,
    }


def mesh_quality(mesh: TetMesh) -> dict:
    """Element counts and worst element quality of a mesh.

    Returns
    -------
    dict
        ``"n_tets"``, ``"n_nodes"``; ``"tets_per_region"`` (region name → count);
        ``"min_dihedral_rad"`` and ``"min_dihedral_deg"`` (smallest dihedral
        angle over all elements); ``"max_dihedral_deg"``; ``"max_aspect_ratio"``
        and ``"mean_aspect_ratio"`` (R / 3r, 1 for a regular tetrahedron);
        ``"min_volume_m3"``.
    """
    q = tet_quality(mesh.points, mesh.tets)
    counts = np.bincount(mesh.region, minlength=len(mesh.region_names))
    min_dih = float(q["min_dihedral"].min())
    return {
        "n_tets": mesh.n_tets,
        "n_nodes": mesh.n_nodes,
        "tets_per_region": {n: int(c) for n, c in zip(mesh.region_names, counts, strict=True)},
        "min_dihedral_rad": min_dih,
        "min_dihedral_deg": float(np.degrees(min_dih)),
        "max_dihedral_deg": float(np.degrees(q["max_dihedral"].max())),
        "max_aspect_ratio": float(q["aspect_ratio"].max()),
        "mean_aspect_ratio": float(q["aspect_ratio"].mean()),
        "min_volume_m3": float(q["volume"].min()),
    }


def node_adjacency(mesh: TetMesh) -> sp.csr_matrix:
    """Symmetric node–node adjacency (nodes sharing a tetrahedron, diagonal included).

    Its sparsity is that of a linear-element stiffness matrix with one unknown
    per node; with 3 unknowns per node numbered node-major the bandwidth is
    3·b + 2.
    """
    t = mesh.tets
    rows = np.repeat(t, 4, axis=1).ravel()
    cols = np.tile(t, (1, 4)).ravel()
    data = np.ones(rows.size, dtype=np.int8)
    a = sp.coo_matrix((data, (rows, cols)), shape=(mesh.n_nodes, mesh.n_nodes)).tocsr()
    a.data[:] = 1
    return a


def bandwidth(a) -> int:
    """Bandwidth max |i − j| over the stored non-zeros of a sparse (or dense) matrix."""
    coo = sp.coo_matrix(a)
    nz = coo.data != 0
    if not nz.any():
        return 0
    return int(np.abs(coo.row[nz].astype(np.int64) - coo.col[nz]).max())


def rcm_permutation(a) -> np.ndarray:
    """Reverse Cuthill–McKee ordering of a square matrix (symmetrised pattern).

    ``perm[k]`` is the old index of new row/column k: ``a[perm][:, perm]`` is the
    reordered matrix.
    """
    csr = sp.csr_matrix(a)
    return np.asarray(reverse_cuthill_mckee(csr, symmetric_mode=True), dtype=np.int64)


def rcm_bandwidth(a) -> tuple[int, int]:
    """Bandwidth of ``a`` before and after reverse Cuthill–McKee reordering.

    Uses ``scipy.sparse.csgraph.reverse_cuthill_mckee(..., symmetric_mode=True)``;
    ``a`` must be square with a symmetric pattern (as stiffness matrices are).
    """
    csr = sp.csr_matrix(a)
    perm = rcm_permutation(csr)
    return bandwidth(csr), bandwidth(csr[perm][:, perm])
