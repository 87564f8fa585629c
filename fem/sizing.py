"""How large a mesh and its model will be, estimated before meshing (no gmsh).

:func:`estimate_mesh_size` gives the tetrahedra, free dofs and bytes of the
pedicle-and-joint model for a geometry, element order and resolution, so that
a command can refuse an over-large mesh up front (:func:`check_mesh_size`)
instead of running until it is killed or out of memory.

The tetrahedra follow the element-size field that
:func:`fem.geometry.build_pedicle_joint` gives gmsh, h(x)/R (its region boxes
with their ramps and the refinement towards the singular edges, reproduced
here): n_tets ≈ c₃ R³ ∫ dV/h³ + c₂ R² ∫ dA/h², the volume of the solid and the
faces of its parts, both integrated adaptively. The face term is needed: gmsh's
meshes grew like R² to R^2.6 between R = 0.35 and 3.5, not R³. The two
coefficients were fitted to 18 gmsh meshes (the default geometry at resolution
0.35–3.5, eight other geometries at 0.7, two of them also at 1.4–2; 3 000 to
553 000 tetrahedra) and reproduce them within :data:`MEASURED_TET_ERROR`.
Nodes and edges (the P2 nodes) come from fits to the same meshes; bytes from
the peak memory (resident set) of meshing, assembling and one static solve of
P1 and P2 models with 17k to 230k dofs (within 2 %).
"""

from __future__ import annotations

import dataclasses
import functools
import os

import numpy as np

from isj.design import Geometry
from isj.errors import InvalidParameter

from .geometry import MeshSizes

#: c₃ (tetrahedra per h³ of solid) and c₂ (per h² of the parts' faces), fitted.
C_VOLUME, C_SURFACE = 2.046, 4.902
#: Largest relative error of the tetrahedron estimate over the meshes it was fitted to
#: (under at R = 0.35 and 3.5, over at R = 1–1.4).
MEASURED_TET_ERROR = 0.15
#: Nodes ≈ a·n_tets + b·n_tets^(2/3) (the capsule's duplicated interface nodes included; within 8 %).
_NODES = (0.1848, 1.859)
#: Edges ≈ nodes + n_tets + c·n_tets^(2/3) (Euler's relation plus the boundary; within 4 %).
_EDGES = 4.62
#: Peak bytes of meshing, assembling and one static solve ≈ a·n_dofs + b·n_dofs^(4/3), per order.
_BYTES = {1: (5490.0, 50.9), 2: (9597.0, 36.9)}
#: Largest estimated memory :func:`check_mesh_size` accepts by default (bytes): 16 GiB, or 80 %
#: of this machine's memory if that is less.
MAX_MODEL_BYTES = 16 * 2**30

#: Levels of the adaptive integration of the size field (cells halve per level).
_MAX_SPLITS = 14
#: Points per block in the distance computation (bounds its temporary arrays to ~40 MB).
_CHUNK = 65536


def _boxes(g: Geometry, s: MeshSizes):
    """(size at resolution 1 (m), box (x0, y0, z0, x1, y1, z1) m) for each solid part, as gmsh gets them."""
    jx, jy, t = g.joint_x_m, g.joint_y_m, g.capsule_thickness_m
    regions = {
        "stapes": (jx, jy, 0.0, g.z_gap),
        "gap": (jx, jy, g.z_gap, g.z_plate),
        "plate": (jx, jy, g.z_plate, g.z_pedicle),
        "pedicle": (g.pedicle_x_m, g.pedicle_y_m, g.z_pedicle, g.z_incus),
        "incus": (g.incus_x_m, g.incus_y_m, g.z_incus, g.z_top),
    }
    out = [
        (s.base_size(n), (-wx / 2, -wy / 2, z0, wx / 2, wy / 2, z1))
        for n, (wx, wy, z0, z1) in regions.items()
    ]
    ax, ay, bx, by = jx / 2, jy / 2, jx / 2 + t, jy / 2 + t
    z0, z1 = g.z_gap - g.capsule_reach_m, g.z_plate + g.capsule_reach_m
    for x0, y0, x1, y1 in ((-bx, -by, -ax, by), (ax, -by, bx, by), (-ax, -by, ax, -ay), (-ax, ay, ax, by)):
        out.append((s.base_size("capsule"), (x0, y0, z0, x1, y1, z1)))
    return out


def _lines(g: Geometry, s: MeshSizes):
    """(segments (k, 2, 3) m, size at the lines, size far away) of each singular-edge refinement."""

    def rectangle(wx: float, wy: float, z: float) -> np.ndarray:
        c = np.array([(-wx, -wy), (wx, -wy), (wx, wy), (-wx, wy)]) / 2
        return np.stack(
            [np.column_stack([c, np.full(4, z)]), np.column_stack([np.roll(c, -1, axis=0), np.full(4, z)])],
            axis=1,
        )

    bond0 = g.z_gap - g.capsule_reach_m + g.capsule_bond_m
    bond1 = g.z_plate + g.capsule_reach_m - g.capsule_bond_m
    jx, jy = g.joint_x_m, g.joint_y_m
    return [
        (
            np.concatenate([rectangle(g.pedicle_x_m, g.pedicle_y_m, z) for z in (g.z_pedicle, g.z_incus)]),
            s.pedicle_edge_m,
            s.base_size("pedicle"),
        ),
        (
            np.concatenate([rectangle(jx, jy, z) for z in (bond0, bond1)]),
            s.capsule_edge_m,
            s.base_size("capsule"),
        ),
        (
            np.concatenate([rectangle(jx, jy, z) for z in (g.z_gap, g.z_plate)]),
            s.gap_edge_m,
            s.base_size("gap"),
        ),
    ]


def _segment_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance (m) from each of ``points`` (n, 3) to the nearest of ``segments`` (k, 2, 3)."""
    a, b = segments[:, 0], segments[:, 1]
    ab = b - a
    t = np.einsum("nkj,kj->nk", points[:, None, :] - a, ab) / np.maximum(
        np.einsum("kj,kj->k", ab, ab), 1e-300
    )
    foot = a + np.clip(t, 0.0, 1.0)[..., None] * ab
    return np.linalg.norm(points[:, None, :] - foot, axis=2).min(axis=1)


def _size_field(points: np.ndarray, boxes, lines, s: MeshSizes) -> np.ndarray:
    """The size gmsh gets at ``points`` (n, 3), resolution 1 (m): Min of the Box and Threshold fields."""
    h_max = max(h for h, _ in boxes)
    h = np.full(len(points), h_max)
    for size, b in boxes:  # VIn inside, rising linearly to VOut over the ramp outside
        lo, hi = np.array(b[:3]), np.array(b[3:])
        d = np.linalg.norm(np.maximum(np.maximum(lo - points, points - hi), 0.0), axis=1)
        ramp = max((h_max - size) / s.grading, 1e-9)
        h = np.minimum(h, size + (h_max - size) * np.minimum(d / ramp, 1.0))
    for segments, h_e, h_f in lines:
        if h_e < h_f:  # a size at least the region's switches the refinement off, as in gmsh
            d = np.concatenate(
                [_segment_distance(points[i : i + _CHUNK], segments) for i in range(0, len(points), _CHUNK)]
            )
            h = np.minimum(h, np.minimum(h_e + s.edge_grading * d, h_f))
    return h


def _integral(cells: np.ndarray, power: int, boxes, lines, s: MeshSizes) -> float:
    """∫ h⁻ᵖ over boxes (k, 6) that are solids (p = 3) or faces (p = 2, one extent zero), adaptively.

    A cell is halved along each extent longer than the size at its centre, so the
    refinement towards the singular edges is resolved and thin layers stay one
    cell thick.
    """
    total = 0.0
    for _ in range(_MAX_SPLITS):
        lo, hi = cells[:, :3], cells[:, 3:]
        ext = hi - lo
        h = _size_field(0.5 * (lo + hi), boxes, lines, s)
        along = ext > h[:, None]  # (k, 3): the extents to halve
        leaf = ~along.any(axis=1)
        measure = np.prod(np.where(ext > 0, ext, 1.0), axis=1)
        total += float(np.sum(measure[leaf] * h[leaf] ** -float(power)))
        if leaf.all():
            return total
        lo, hi, along = lo[~leaf], hi[~leaf], along[~leaf]
        mid = 0.5 * (lo + hi)
        children = []
        for corner in np.ndindex(2, 2, 2):
            upper = np.array(corner, dtype=bool)
            take = ~(upper & ~along).any(axis=1)  # a corner only along the halved extents
            new_lo = np.where(upper & along, mid, lo)
            new_hi = np.where(~upper & along, mid, hi)
            children.append(np.hstack([new_lo, new_hi])[take])
        cells = np.concatenate(children)
    return total + float(np.sum(measure[~leaf] * h[~leaf] ** -float(power)))  # deepest level, unsplit


def _features(g: Geometry, s: MeshSizes) -> tuple[float, float]:
    """(∫ dV / h³ over the solid, ∫ dA / h² over the faces of its parts) at resolution 1 (m⁰)."""
    boxes = _boxes(g, s)
    lines = _lines(g, s)
    solids = np.array([b for _, b in boxes], dtype=float)
    faces = []
    for b in solids:
        for axis in range(3):
            for side in (0, 3):
                f = b.copy()
                f[axis] = f[axis + 3] = b[axis + side]
                faces.append(f)
    return _integral(solids, 3, boxes, lines, s), _integral(np.array(faces), 2, boxes, lines, s)


@functools.lru_cache(maxsize=64)
def _cached_features(g: Geometry, s: MeshSizes) -> tuple[float, float]:
    return _features(g, s)


def _check(order, resolution) -> None:
    if order not in (1, 2) or isinstance(order, bool):
        raise InvalidParameter(f"order = {order!r}: must be 1 or 2")
    if isinstance(resolution, bool) or not isinstance(resolution, int | float) or not 0 < resolution < np.inf:
        raise InvalidParameter(f"resolution = {resolution!r}: must be a finite number > 0")


def _estimate(features: tuple[float, float], order: int, r: float) -> tuple[int, int, int]:
    volume, surface = features
    n_tets = r**3 * C_VOLUME * volume + r**2 * C_SURFACE * surface
    n_nodes = _NODES[0] * n_tets + _NODES[1] * n_tets ** (2 / 3)
    if order == 2:  # one more node on every edge
        n_nodes += n_nodes + n_tets + _EDGES * n_tets ** (2 / 3)
    n_dofs = 3 * n_nodes  # the clamped face's few dofs are not taken off
    a, b = _BYTES[order]
    return int(round(n_tets)), int(round(n_dofs)), int(round(a * n_dofs + b * n_dofs ** (4 / 3)))


def estimate_mesh_size(
    geometry: Geometry | None = None, order: int = 2, resolution: float = 1.0, sizes: MeshSizes | None = None
) -> tuple[int, int, int]:
    """Tetrahedra, free dofs and peak bytes of the pedicle-and-joint model, before meshing.

    Parameters
    ----------
    geometry : dimensions (m); default :class:`~isj.design.Geometry()`
    order : 1 or 2 (P1 or P2 tetrahedra)
    resolution : refinement factor R (> 0) dividing every element size
    sizes : element sizes at resolution 1 (m); default :class:`MeshSizes()`

    Returns
    -------
    (n_tets, n_dofs, bytes)
        Estimates: the tetrahedra within about :data:`MEASURED_TET_ERROR` on the
        meshes measured; bytes the peak memory of meshing, assembling and one
        static solve (a harmonic or modal solve needs more: a second factorization).
        The cost is the size field's integrals, cached per geometry.
    """
    _check(order, resolution)
    s = sizes or MeshSizes()
    features = _cached_features(geometry or Geometry(), dataclasses.replace(s, resolution=1.0))
    return _estimate(features, order, float(resolution) * s.resolution)


def max_model_bytes() -> int:
    """:data:`MAX_MODEL_BYTES`, or 80 % of this machine's physical memory if that is less (bytes)."""
    try:
        physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return MAX_MODEL_BYTES
    return int(min(MAX_MODEL_BYTES, 0.8 * physical))


def check_mesh_size(
    geometry: Geometry | None = None,
    order: int = 2,
    resolution: float = 1.0,
    max_bytes: int | None = None,
    name: str = "resolution",
) -> tuple[int, int, int]:
    """:func:`estimate_mesh_size`, refusing a model whose estimated memory exceeds ``max_bytes``.

    Parameters
    ----------
    geometry, order, resolution : as for :func:`estimate_mesh_size`
    max_bytes : the limit (bytes); default :func:`max_model_bytes`
    name : the parameter to name in the message (``"--resolution"`` on the command line)

    Returns
    -------
    (n_tets, n_dofs, bytes)
        The estimate, if it fits.

    Raises
    ------
    InvalidParameter
        One line naming ``name``, the estimate, and the largest resolution that fits.
    """
    _check(order, resolution)
    limit = max_model_bytes() if max_bytes is None else int(max_bytes)
    est = estimate_mesh_size(geometry, order, resolution)
    if est[2] <= limit:
        return est
    features = _cached_features(geometry or Geometry(), MeshSizes())
    lo, hi = 0.0, float(resolution)  # the estimate grows with the resolution: bisect the largest that fits
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _estimate(features, order, mid)[2] <= limit else (lo, mid)
    raise InvalidParameter(
        f"{name} = {resolution!r}: the P{order} model would need about {est[2] / 2**30:.3g} GiB "
        f"({est[0]:.3g} tetrahedra, {est[1]:.3g} dofs), over the {limit / 2**30:.3g} GiB limit; "
        f"must be <= {lo:.3g} for this geometry"
    )
