"""Checks of a user mesh (:mod:`fem.user_mesh`): elements, conformity, contact, named faces.

Each check raises :class:`~isj.errors.InvalidMesh` with one line naming the
first problem found. Tetrahedra are numbered from 1 in the order the file lists
them (all tetrahedra blocks, in file order).

Conformity rests on two facts of a conforming tetrahedral mesh: no two
distinct nodes coincide, and its boundary triangles (faces of one tetrahedron
only) lie on its outer surface, so none lies on another with the solid on both
sides. Two regions meshed separately fail the first where their nodes meet and
the second where they do not (a hanging node, a face split on one side only).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from isj.design import REGIONS
from isj.errors import InvalidMesh

#: Local vertices of the four faces of a tetrahedron (face f opposite vertex f).
_TET_FACES = np.array([(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)])
#: Node ids must stay below this for the int64 face keys (n³ < 2⁶³).
MAX_NODES = 2**21 - 1
#: A tetrahedron whose |det J| is at most this times its longest edge cubed is degenerate.
DEGENERATE_REL = 1e-10
#: Distinct nodes closer than this times the mesh's bounding-box diagonal are duplicates.
DUPLICATE_REL = 1e-9


def _fmt(p) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in p) + ") m"


def check_geometry(path, points: np.ndarray, tets: np.ndarray, region: np.ndarray) -> None:
    """No coordinate that is not finite, no inverted or degenerate tetrahedron, no two distinct
    nodes at one place."""
    if not np.isfinite(points).all():  # read_mesh names the node; this guards other callers
        raise InvalidMesh(f"{path}: a node has a coordinate that is not a finite number")
    p = points[tets]
    e = p[:, 1:] - p[:, :1]  # (n, 3, 3)
    det = np.einsum("ij,ij->i", np.cross(e[:, 0], e[:, 1]), e[:, 2])
    pairs = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
    longest = np.linalg.norm(p[:, pairs[:, 1]] - p[:, pairs[:, 0]], axis=2).max(axis=1)
    degenerate = np.abs(det) <= DEGENERATE_REL * longest**3
    bad = np.flatnonzero(degenerate | (det < 0))
    if bad.size:
        k = int(bad[0])
        what = (
            "degenerate (flat)"
            if degenerate[k]
            else "inverted (negative volume: its nodes are in the wrong order)"
        )
        raise InvalidMesh(
            f"{path}: tetrahedron {k + 1} (region {REGIONS[region[k]]}, at {_fmt(p[k].mean(axis=0))}) "
            f"is {what}: volume {det[k] / 6:.3e} m^3; {bad.size} such tetrahedra in all"
        )
    used = np.unique(tets)
    diag = float(np.linalg.norm(np.ptp(points, axis=0)))
    close = cKDTree(points[used]).query_pairs(DUPLICATE_REL * diag, output_type="ndarray")
    if len(close):
        i, j = used[close[0, 0]], used[close[0, 1]]
        node_region = np.full(len(points), -1, dtype=np.int64)
        node_region[tets.ravel()] = np.repeat(region, 4)
        a, b = REGIONS[node_region[i]], REGIONS[node_region[j]]
        where = f"between regions {a} and {b}" if a != b else f"in region {a}"
        raise InvalidMesh(
            f"{path}: non-conforming interface {where}: {len(close)} node(s) duplicated, "
            f"e.g. nodes {i + 1} and {j + 1} at {_fmt(points[i])}; neighbouring elements must share nodes"
        )


def hanging_faces(path, points, tri, tet_of, region) -> None:
    """Refuse boundary triangles lying inside another, facing it: a face split on one side only.

    For each boundary triangle g, the boundary triangles whose centroids lie within g's
    circumscribing ball are tested: coplanar with g (within 1e-6 of its size), facing the
    other way, centroid inside g.
    """
    p = points[tri]  # (n, 3, 3)
    c = p.mean(axis=1)
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area2 = np.linalg.norm(normal, axis=1)
    unit = normal / area2[:, None]
    radius = np.linalg.norm(p - c[:, None, :], axis=2).max(axis=1)
    tree = cKDTree(c)
    hits = tree.query_ball_point(c, radius * (1 + 1e-9))
    g = np.repeat(np.arange(len(tri)), [len(h) for h in hits])
    f = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits]) if len(hits) else np.empty(0, int)
    keep = f != g
    g, f = g[keep], f[keep]
    facing = np.einsum("ij,ij->i", unit[g], unit[f]) < -0.99
    g, f = g[facing], f[facing]
    d = c[f] - p[g, 0]
    plane = np.abs(np.einsum("ij,ij->i", d, unit[g])) <= 1e-6 * radius[g]
    g, f, d = g[plane], f[plane], d[plane]
    # barycentric coordinates of f's centroid in g
    e1, e2 = p[g, 1] - p[g, 0], p[g, 2] - p[g, 0]
    n = normal[g]
    l1 = np.einsum("ij,ij->i", np.cross(d, e2), n) / area2[g] ** 2
    l2 = np.einsum("ij,ij->i", np.cross(e1, d), n) / area2[g] ** 2
    inside = (l1 > 1e-9) & (l2 > 1e-9) & (l1 + l2 < 1 - 1e-9)
    if inside.any():
        k = int(np.flatnonzero(inside)[0])
        a, b = REGIONS[region[tet_of[g[k]]]], REGIONS[region[tet_of[f[k]]]]
        where = f"between regions {a} and {b}" if a != b else f"in region {a}"
        raise InvalidMesh(
            f"{path}: non-conforming interface {where} at {_fmt(c[f[k]])}: boundary faces lie on one "
            f"another without sharing nodes ({int(inside.sum())} such pairs; a hanging node, or a face "
            "split on one side only)"
        )


@dataclass(frozen=True)
class Topology:
    """Faces of a checked mesh: unique sorted node triples, their tetrahedra and regions."""

    keys: np.ndarray  # (n_faces,) sorted int64 keys of the unique faces
    count: np.ndarray  # tetrahedra per face (1 boundary, 2 interior)
    regions: np.ndarray  # (n_faces, 2) region ids of the two tets (the same twice on the boundary)
    n_nodes: int

    def key_of(self, tri: np.ndarray) -> np.ndarray:
        s = np.sort(tri, axis=1).astype(np.int64)
        n = np.int64(self.n_nodes)
        return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]

    def find(self, tri: np.ndarray) -> np.ndarray:
        """Face index of each triangle, −1 where it is no face of the mesh."""
        k = self.key_of(tri)
        pos = np.minimum(np.searchsorted(self.keys, k), len(self.keys) - 1)
        return np.where(self.keys[pos] == k, pos, -1)

    def capsule_interface_without(self, free: np.ndarray) -> np.ndarray:
        """Node triples of the capsule's faces bonded to another region, except those in ``free``."""
        cap = REGIONS.index("capsule")
        r = self.regions
        on = (self.count == 2) & ((r[:, 0] == cap) != (r[:, 1] == cap))
        on[self.find(free)] = False
        k = self.keys[on]
        n = np.int64(self.n_nodes)
        return np.column_stack([k // (n * n), (k // n) % n, k % n])


def check_topology(path, points, tets, region, faces: dict[str, np.ndarray]) -> Topology:
    """Conforming faces, every region bonded to another and to the clamped face, valid named faces."""
    n_nodes = len(points)
    if n_nodes > MAX_NODES:
        raise InvalidMesh(f"{path}: {n_nodes} nodes, over the {MAX_NODES} these checks handle")
    n = np.int64(n_nodes)
    tf = np.sort(tets[:, _TET_FACES].reshape(-1, 3), axis=1)
    key = (tf[:, 0] * n + tf[:, 1]) * n + tf[:, 2]
    keys, first, inv, count = np.unique(key, return_index=True, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    owner = np.arange(len(key)) // 4  # tet of each local face
    if (count > 2).any():
        f = int(np.flatnonzero(count > 2)[0])
        t = owner[first[f]]
        raise InvalidMesh(
            f"{path}: a triangle at {_fmt(points[tf[first[f]]].mean(axis=0))} is a face of "
            f"{count[f]} tetrahedra (overlapping elements, e.g. tetrahedron {t + 1}, "
            f"region {REGIONS[region[t]]})"
        )
    # the two tets of each face (the same one twice on the boundary)
    order = np.argsort(inv, kind="stable")
    starts = np.concatenate([[0], np.cumsum(count)[:-1]])
    second = owner[order[starts + count - 1]]
    pair = np.column_stack([owner[first], second])
    regions = region[pair].astype(np.int64)

    hanging_faces(path, points, tf[first[count == 1]], owner[first[count == 1]], region)

    # each region bonded to another through a shared face, all of them to the clamped face
    inner = (count == 2) & (regions[:, 0] != regions[:, 1])
    nr = len(REGIONS)
    adj = np.zeros((nr, nr), dtype=bool)
    adj[regions[inner, 0], regions[inner, 1]] = adj[regions[inner, 1], regions[inner, 0]] = True
    present = np.unique(region)
    for r in present:
        if not adj[r].any():
            raise InvalidMesh(
                f"{path}: region {REGIONS[r]} touches no other region (shares no face with one)"
            )
    interior = count == 2
    graph = sp.coo_matrix(
        (np.ones(int(interior.sum())), (pair[interior, 0], pair[interior, 1])), shape=(len(tets),) * 2
    )
    n_comp, label = connected_components(graph, directed=False)
    topo = Topology(keys=keys, count=count, regions=regions, n_nodes=n_nodes)

    for name, tri in faces.items():
        idx = topo.find(tri)
        if (idx < 0).any():
            k = int(np.flatnonzero(idx < 0)[0])
            raise InvalidMesh(
                f"{path}: face group {name!r}: triangle {k + 1} at {_fmt(points[tri[k]].mean(axis=0))} "
                f"is no face of a tetrahedron ({int((idx < 0).sum())} such triangles)"
            )
        if name == "capsule_free":
            cap = REGIONS.index("capsule")
            ok = (count[idx] == 2) & ((regions[idx, 0] == cap) != (regions[idx, 1] == cap))
            what = "on the capsule's interface with another region"
        else:
            ok = count[idx] == 1
            what = "on the boundary"
        if not ok.all():
            k = int(np.flatnonzero(~ok)[0])
            raise InvalidMesh(
                f"{path}: face group {name!r}: {int((~ok).sum())} triangles are not {what}, e.g. at "
                f"{_fmt(points[tri[k]].mean(axis=0))}"
            )
    if n_comp > 1:
        clamped_tets = pair[topo.find(faces["clamped"]), 0]
        held = np.isin(label, np.unique(label[clamped_tets]))
        if not held.all():
            t = int(np.flatnonzero(~held)[0])
            rs = sorted({REGIONS[r] for r in np.unique(region[~held])})
            raise InvalidMesh(
                f"{path}: {int((~held).sum())} tetrahedra (region {', '.join(rs)}, e.g. tetrahedron {t + 1}) "
                "are connected to nothing clamped: no chain of shared faces leads to the clamped face"
            )
    return topo
