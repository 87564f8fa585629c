"""Structured tetrahedral meshes of a box, without gmsh.

Used for verification (patch tests, beam solutions) independent of the gmsh
builder: each hexahedral cell is split into six tetrahedra around its main
diagonal (Kuhn triangulation), which is conforming across cells.
"""

from __future__ import annotations

import numpy as np

# Kuhn split: the six monotone paths from corner 0 to corner 7 of a unit cube,
# corners numbered by bits (x, y, z) = (1, 2, 4).
_KUHN = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]])


def box_mesh(lengths_m, divisions, origin_m=(0.0, 0.0, 0.0), region_name: str = "box"):
    """Tetrahedral mesh of the box ``origin + [0, Lx] × [0, Ly] × [0, Lz]``.

    Parameters
    ----------
    lengths_m : (3,) box edge lengths (m)
    divisions : (3,) number of cells along x, y, z
    origin_m : (3,) lower corner (m)

    Returns
    -------
    fem.mesh.TetMesh with one region and faces ``"x0", "x1", "y0", "y1",
    "z0", "z1"`` (the box's six sides), plus ``"clamped"`` = ``"z0"`` and
    ``"loaded"`` = ``"z1"`` (the cantilever convention).
    """
    from .mesh import TetMesh

    nx, ny, nz = (int(n) for n in divisions)
    if min(nx, ny, nz) < 1:
        raise ValueError(f"divisions = {divisions!r}: each must be >= 1")
    axes = [np.linspace(o, o + L, n + 1) for o, L, n in zip(origin_m, lengths_m, (nx, ny, nz), strict=True)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)

    def nid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    corners = np.stack([nid(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)) for c in range(8)], axis=1)
    tets = corners[:, _KUHN].reshape(-1, 4)
    # orient every tetrahedron positively
    p = points[tets]
    det = np.linalg.det(np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]], 2))
    neg = det < 0
    tets[neg, 2], tets[neg, 3] = tets[neg, 3].copy(), tets[neg, 2].copy()

    faces = {}
    for axis, name in enumerate("xyz"):
        for side, val in ((0, 0), (1, (nx, ny, nz)[axis])):
            idx = [np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1)]
            idx[axis] = np.array([val])
            a, b, c = np.meshgrid(*idx, indexing="ij")
            grid = nid(a, b, c).squeeze(axis=axis)
            q = np.stack([grid[:-1, :-1], grid[1:, :-1], grid[1:, 1:], grid[:-1, 1:]], axis=-1).reshape(-1, 4)
            faces[f"{name}{side}"] = np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    # the quad split above must match the tets' diagonals: Kuhn splits every
    # face along its diagonal through the cube's corner 0, i.e. (0, 2) here
    faces["clamped"] = faces["z0"]
    faces["loaded"] = faces["z1"]
    return TetMesh(
        points=points,
        tets=tets.astype(np.int64),
        region=np.zeros(tets.shape[0], dtype=np.int8),
        region_names=(region_name,),
        faces=faces,
    )
