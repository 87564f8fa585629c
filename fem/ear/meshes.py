"""Small structured triangulations for verifying the shell element, without gmsh.

All are deterministic and return ``(nodes_m (N, 3), triangles (M, 3))`` plus named
node sets; triangles are counter-clockwise seen from +z (disk, rectangle) or
from outside (sphere), so :func:`fem.ear.shell.pressure_load` pushes along +z or outwards.
"""

from __future__ import annotations

import numpy as np

from isj.errors import InvalidParameter


def _check_count(name: str, value: int, minimum: int) -> int:
    if not isinstance(value, int | np.integer) or value < minimum:
        raise InvalidParameter(f"{name} = {value!r}: must be an integer >= {minimum}")
    return int(value)


def _orient_up(nodes, tris):
    """Flip triangles whose normal has a negative z component."""
    p = nodes[tris]
    nz = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]
    tris = tris.copy()
    tris[nz < 0] = tris[nz < 0][:, [0, 2, 1]]
    return tris


def zip_rings(a: int, m_in: int, b: int, m_out: int) -> list[list[int]]:
    """Triangles between two closed rings of m_in and m_out nodes starting at ids a and b (same angle 0)."""
    tris = []
    i = o = 0
    while i < m_in or o < m_out:
        # next node in angle, decided with exact integer arithmetic: (o+1)/m_out vs (i+1)/m_in
        if i == m_in or (o < m_out and (o + 1) * m_in <= (i + 1) * m_out):
            tris.append([a + i % m_in, b + o, b + (o + 1) % m_out])
            o += 1
        else:
            tris.append([a + i, b + o % m_out, a + (i + 1) % m_in])
            i += 1
    return tris


def disk_mesh(radius_m: float, n_rings: int):
    """Polar triangulation of a disk of radius ``radius_m`` (m) in the plane z = 0.

    Ring k (k = 1..n_rings) at radius k/n_rings × radius has 6k equally spaced nodes,
    so the triangles stay near-equilateral at every refinement; neighbouring rings
    are zipped together by walking both in angle.

    Returns
    -------
    nodes (N, 3), triangles (M, 3), {"centre": [0], "boundary": outer ring node ids}
    """
    n = _check_count("n_rings", n_rings, 1)
    pts = [np.zeros((1, 3))]
    first = [0]
    for k in range(1, n + 1):
        phi = 2.0 * np.pi * np.arange(6 * k) / (6 * k)
        r = radius_m * k / n
        pts.append(np.stack([r * np.cos(phi), r * np.sin(phi), np.zeros_like(phi)], axis=1))
        first.append(first[-1] + (1 if k == 1 else 6 * (k - 1)))
    nodes = np.concatenate(pts)
    tris = [[0, 1 + j, 1 + (j + 1) % 6] for j in range(6)]
    for k in range(2, n + 1):
        m_in, m_out = 6 * (k - 1), 6 * k
        tris += zip_rings(first[k - 1], m_in, first[k], m_out)
    tris = _orient_up(nodes, np.array(tris, dtype=np.int64))
    return nodes, tris, {"centre": np.array([0]), "boundary": np.arange(first[n], len(nodes))}


def rectangle_mesh(lx_m: float, ly_m: float, nx: int, ny: int):
    """Rectangle [0, lx] × [0, ly] (m) in z = 0, nx × ny cells, each cut by its shorter-sum diagonal.

    Diagonals alternate in a chequerboard, which keeps the mesh free of a preferred direction.

    Returns
    -------
    nodes (N, 3), triangles (M, 3), node sets "x0", "x1", "y0", "y1" (the four edges)
    """
    nx = _check_count("nx", nx, 1)
    ny = _check_count("ny", ny, 1)
    X, Y = np.meshgrid(np.linspace(0.0, lx_m, nx + 1), np.linspace(0.0, ly_m, ny + 1), indexing="ij")
    nodes = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)

    def nid(i, j):
        return i * (ny + 1) + j

    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    n00, n10, n01, n11 = nid(i, j), nid(i + 1, j), nid(i, j + 1), nid(i + 1, j + 1)
    even = (i + j) % 2 == 0
    t1 = np.where(even[:, None], np.stack([n00, n10, n11], 1), np.stack([n00, n10, n01], 1))
    t2 = np.where(even[:, None], np.stack([n00, n11, n01], 1), np.stack([n10, n11, n01], 1))
    tris = _orient_up(nodes, np.concatenate([t1, t2]))
    ii, jj = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), indexing="ij")
    sets = {
        "x0": nid(0, np.arange(ny + 1)),
        "x1": nid(nx, np.arange(ny + 1)),
        "y0": nid(np.arange(nx + 1), 0),
        "y1": nid(np.arange(nx + 1), ny),
    }
    return nodes, tris, sets


def icosphere(radius_m: float, level: int):
    """Sphere of radius ``radius_m`` (m): an icosahedron with each face split into 4, ``level`` times.

    Returns
    -------
    nodes (10 × 4**level + 2, 3) on the sphere, triangles (20 × 4**level, 3) with outward normals
    """
    level = _check_count("level", level, 0)
    g = (1.0 + 5.0**0.5) / 2.0
    v = np.array(
        [
            [-1, g, 0],
            [1, g, 0],
            [-1, -g, 0],
            [1, -g, 0],
            [0, -1, g],
            [0, 1, g],
            [0, -1, -g],
            [0, 1, -g],
            [g, 0, -1],
            [g, 0, 1],
            [-g, 0, -1],
            [-g, 0, 1],
        ],
        dtype=float,
    )
    f = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ],
        dtype=np.int64,
    )
    v = v / np.linalg.norm(v, axis=1)[:, None]
    for _ in range(level):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mid = v[uniq].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1)[:, None]
        m = len(f)
        a, b, c = (len(v) + inv.ravel()[k * m : (k + 1) * m] for k in range(3))  # mids of 01, 12, 20
        v = np.concatenate([v, mid])
        f = np.concatenate(
            [np.stack(t, 1) for t in ([f[:, 0], a, c], [a, f[:, 1], b], [c, b, f[:, 2]], [a, b, c])]
        )
    # Outward orientation: normal · centroid > 0.
    p = v[f]
    out = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p.mean(axis=1)) > 0
    f[~out] = f[~out][:, [0, 2, 1]]
    return radius_m * v, f
