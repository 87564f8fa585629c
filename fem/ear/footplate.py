"""The stapes footplate (docs/ear.md §5.5): an elliptical shell with a thick rim, and its annular springs.

The footplate is a flat elliptical plate of the existing shell element
(:mod:`fem.ear.shell`), E = 20 GPa, 20 µm thick in the centre and 200 µm in
the rim. Its structured mesh has ``rings`` rings of nodes around a centre node;
ring k < rings lies at the fraction (1 − rim) k / (rings − 1) of the outline, the
last ring on the outline itself, so the outermost annulus of triangles is the
thick rim (width ``rim`` × the radius).

Node sets:

- ``"centre"``: the centre node (the footplate displacement is read there);
- ``"outline"``: the last ring, ``annular_springs`` equally spaced nodes (in the
  ellipse's parametric angle) carrying the annular ligament + cochlear load
  springs (docs/ear.md §5.5: 40 out-of-plane springs of 11 N/m, in-plane springs of 9.9 N/m);
- ``"crura"``: the ring at the inner edge of the rim, where the crura meet the
  footplate. The whole-ear model ties all of it to the stapes superstructure
  (a band of many nodes, never a few corner nodes, which gave the thesis
  displacement spikes), so the ligament's forces reach the crura through the
  thick rim.

SI units: m, Pa, N/m.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from isj.ear import EarGeometry, EarMaterials

from .meshes import zip_rings
from .shell import NDOF, ShellMaterial, stiffness_matrix

#: Bone density of the footplate (kg/m³): an estimate, as for the ossicles (docs/model.md §2.1);
#: statics ignore it.
FOOTPLATE_DENSITY_KG_M3 = 2000.0


@dataclass(frozen=True, eq=False)
class FootplateMesh:
    """Triangle mesh of the footplate in the ear's frame.

    Attributes
    ----------
    nodes_m : (N, 3) coordinates (m)
    triangles : (M, 3) node ids; normals along the piston direction
    rim : (M,) True for the triangles of the thick rim
    node_sets : "centre", "outline", "crura"
    normal : (3,) unit piston direction (into the cochlea)
    """

    nodes_m: np.ndarray
    triangles: np.ndarray
    rim: np.ndarray
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    normal: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))


def ring_counts(rings: int, outline: int) -> np.ndarray:
    """Nodes on each ring k = 1..rings: ≈ outline × k / rings, at least 3, the last exactly ``outline``."""
    k = np.arange(1, rings + 1)
    return np.maximum(3, np.rint(outline * k / rings).astype(int))


def footplate_mesh(geometry: EarGeometry | None = None) -> FootplateMesh:
    """Structured elliptical mesh of the footplate, placed and oriented in the ear (deterministic)."""
    g = geometry or EarGeometry()
    n = g.footplate_rings
    counts = ring_counts(n, g.annular_springs)
    radius = np.concatenate([(1.0 - g.footplate_rim_fraction) * np.arange(1, n) / (n - 1), [1.0]])
    long_m, short_m = g.footplate_semi_axes_m
    pts = [np.zeros((1, 2))]
    first = [0, 1]
    for k in range(n):
        phi = 2.0 * np.pi * np.arange(counts[k]) / counts[k]
        pts.append(radius[k] * np.stack([long_m * np.cos(phi), short_m * np.sin(phi)], axis=1))
        first.append(first[-1] + counts[k])
    uv = np.concatenate(pts)
    tris = [[0, 1 + j, 1 + (j + 1) % counts[0]] for j in range(counts[0])]
    for k in range(1, n):
        tris += zip_rings(first[k], counts[k - 1], first[k + 1], counts[k])
    tris = np.array(tris, dtype=np.int64)
    # orient counter-clockwise in (u, v): with e_long × e_short = normal, normals point along the piston
    p = uv[tris]
    cross = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (
        p[:, 2, 0] - p[:, 0, 0]
    )
    tris[cross < 0] = tris[cross < 0][:, [0, 2, 1]]
    normal = np.asarray(g.piston_direction)
    e_long = np.asarray(g.footplate_long_axis)
    e_short = np.cross(normal, e_long)
    nodes = np.asarray(g.footplate_centre_m) + uv[:, :1] * e_long + uv[:, 1:] * e_short
    outline = np.arange(first[n], first[n + 1])
    crura = np.arange(first[n - 1], first[n])
    rim = np.isin(tris, outline).any(axis=1)
    return FootplateMesh(
        nodes_m=nodes,
        triangles=tris,
        rim=rim,
        node_sets={"centre": np.array([0]), "outline": outline, "crura": crura},
        normal=normal,
    )


def footplate_stiffness(mesh: FootplateMesh, geometry: EarGeometry, materials: EarMaterials) -> sp.csr_matrix:
    """Shell stiffness (6N × 6N) of the footplate: centre and rim triangles with their own thickness."""
    g, m = geometry, materials
    centre = ShellMaterial(
        m.footplate_e_pa, m.footplate_nu, g.footplate_centre_thickness_m, FOOTPLATE_DENSITY_KG_M3
    )
    rim = ShellMaterial(
        m.footplate_e_pa, m.footplate_nu, g.footplate_rim_thickness_m, FOOTPLATE_DENSITY_KG_M3
    )
    K = stiffness_matrix(mesh.nodes_m, mesh.triangles[~mesh.rim], centre)
    return (K + stiffness_matrix(mesh.nodes_m, mesh.triangles[mesh.rim], rim)).tocsr()


def annular_springs(mesh: FootplateMesh, materials: EarMaterials) -> sp.csr_matrix:
    """Annular ligament + cochlear load (6N × 6N): at each outline node, grounded springs of
    ``annular_out_of_plane_n_m`` along the piston direction n and ``annular_in_plane_n_m`` along
    each in-plane direction: the 3 × 3 block k_out n nᵀ + k_in (I − n nᵀ) on its translations (N/m)."""
    n = mesh.normal
    block = materials.annular_out_of_plane_n_m * np.outer(n, n) + materials.annular_in_plane_n_m * (
        np.eye(3) - np.outer(n, n)
    )
    nodes = mesh.node_sets["outline"]
    dofs = NDOF * nodes[:, None] + np.arange(3)
    rows = np.repeat(dofs, 3, axis=1).ravel()
    cols = np.tile(dofs, (1, 3)).ravel()
    vals = np.tile(block.ravel(), len(nodes))
    size = NDOF * len(mesh.nodes_m)
    return sp.coo_matrix((vals, (rows, cols)), shape=(size, size)).tocsr()
