"""The user's own mesh: read a volume mesh with named groups, check it, write the built-in one.

:func:`read_mesh` reads a gmsh ``.msh`` (2.2 or 4.1, ASCII or binary) or any
volume format meshio reads, with groups named after the six regions of
:data:`isj.design.REGIONS` and the faces ``loaded`` and ``clamped``, plus an
optional ``capsule_free`` interface (docs/model.md §2.11). Groups are gmsh
physical groups (or meshio ``cell_sets``, or an integer cell datum with
``field_data`` naming its values, or meshio's ``a-b-c`` integer cell datum).
Tetrahedra are ``tetra`` (4 nodes) or ``tetra10``; of a ``tetra10`` only the corners are kept (straight-sided
geometry, the P1/P2 space is then built from them as for the built-in mesh).
The file must be conforming (neighbouring elements share their nodes); the
``capsule_free`` triangles are cut open here, as :func:`fem.mesh.mesh_pedicle_joint`
does. Every problem is one line (:class:`~isj.errors.InvalidMesh`).

:func:`write_mesh` writes a :class:`~fem.mesh.TetMesh` as gmsh 2.2 ASCII with
those groups (the free interface closed again, coordinates to 17 digits: the
file reads back to the identical mesh).
"""

from __future__ import annotations

import contextlib
import io
import os
import warnings
from pathlib import Path

import numpy as np

from isj.design import REGIONS
from isj.errors import InvalidMesh, IsjWarning, MeshError

from .mesh import (
    TetMesh,
    _cut_free_interface,
    _openmp_threads_kept,
    _orient_faces,
    import_gmsh,
    initialize_gmsh,
)
from .sizing import _BYTES, _EDGES, max_model_bytes
from .user_checks import (
    check_geometry,
    check_topology,
)

#: Face groups every mesh needs, and the optional one.
REQUIRED_FACES = ("loaded", "clamped")
OPTIONAL_FACES = ("capsule_free",)
#: meshio cell types accepted as tetrahedra and as triangles (corners first in both).
TET_TYPES = {"tetra": 4, "tetra10": 10}
TRI_TYPES = {"triangle": 3, "triangle6": 6}
#: meshio volume cell types refused by name.
OTHER_VOLUME_TYPES = (
    "hexahedron",
    "hexahedron20",
    "hexahedron27",
    "wedge",
    "wedge15",
    "pyramid",
    "pyramid13",
)
#: A tetra10 mid-edge node farther than this times its edge from the midpoint makes a warning.
CURVED_REL = 1e-6
#: Length units accepted for the file's coordinates (metres per unit).
UNITS_M = {"m": 1.0, "mm": 1e-3, "um": 1e-6}
#: Extents (m) of a mesh's bounding box outside which its unit is probably wrong: the
#: incus-stapes joint model spans about 1 mm (docs/model.md §2.2); a box more than 5 cm wide
#: (larger than a cat's middle ear) or less than 10 µm (thinner than the gap) warns.
PLAUSIBLE_EXTENT_M = (1e-5, 5e-2)


# --------------------------------------------------------------------------- size


def estimate_model_bytes(n_vertices: int, n_tets: int, order: int) -> tuple[int, int]:
    """(dofs, peak bytes) of a model with ``n_vertices`` and ``n_tets`` (fem.sizing's fit)."""
    n_nodes = float(n_vertices)
    if order == 2:  # one node per edge: Euler's relation plus the boundary, as in fem.sizing
        n_nodes += n_vertices + n_tets + _EDGES * n_tets ** (2 / 3)
    n_dofs = 3 * n_nodes
    a, b = _BYTES[order]
    return int(round(n_dofs)), int(round(a * n_dofs + b * n_dofs ** (4 / 3)))


def _refuse_size(path, order, n_dofs, nbytes, limit, what) -> None:
    if nbytes > limit:
        raise InvalidMesh(
            f"{path}: the P{order} model would need about {nbytes / 2**30:.3g} GiB ({what}, "
            f"{n_dofs:.3g} dofs), over the {limit / 2**30:.3g} GiB limit; coarsen the mesh or use --order 1"
        )


def check_size(path, n_vertices: int, n_tets: int, order: int, max_bytes: int | None = None) -> None:
    """Refuse (InvalidMesh) a mesh whose model's estimated peak memory exceeds the limit."""
    limit = max_model_bytes() if max_bytes is None else int(max_bytes)
    n_dofs, nbytes = estimate_model_bytes(n_vertices, n_tets, order)
    _refuse_size(path, order, n_dofs, nbytes, limit, f"{n_tets} tetrahedra, {n_vertices} vertices")


def msh_node_count(path) -> int | None:
    """The node count in an ASCII gmsh file's ``$Nodes`` header, read without reading the nodes."""
    try:
        with open(path, "rb") as f:
            head = f.readline()
            if not head.startswith(b"$MeshFormat"):
                return None
            fmt = f.readline().split()
            if len(fmt) < 2 or fmt[1] != b"0":  # binary: leave it to the reader
                return None
            for line in f:
                if line.startswith(b"$Nodes"):
                    counts = f.readline().split()
                    return int(counts[1] if fmt[0].startswith(b"4") else counts[0])
    except (OSError, ValueError, IndexError):
        return None
    return None


def _precheck_size(path, order: int, max_bytes: int | None) -> None:
    """Before the file is read: its node count bounds the model from below (ASCII .msh only).

    The file's nodes are at least the P2 model's nodes' share of a tetra10 file and
    all of a tetra file's vertices; an eighth of them bounds a P1 model's vertices.
    """
    n = msh_node_count(path)
    if n is None:
        return
    limit = max_model_bytes() if max_bytes is None else int(max_bytes)
    dofs = 3 * (n if order == 2 else n / 8)
    a, b = _BYTES[order]
    _refuse_size(
        path, order, int(dofs), a * dofs + b * dofs ** (4 / 3), limit, f"at least, from its {n} nodes"
    )


# --------------------------------------------------------------------------- reading


def _read_meshio(path: Path):
    import meshio

    if not path.is_file():
        raise InvalidMesh(f"{path}: no such file")
    said = io.StringIO()
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            warnings.simplefilter("ignore")  # meshio's notes on what it skips, and stray output
            return meshio.read(path)
    except (Exception, SystemExit) as exc:  # meshio raises ReadError, KeyError, ... or exits on bad files
        if path.suffix.lower() == ".msh":
            try:  # e.g. 4.1 with "save all": meshio 5.3 fails on entities outside physical groups
                return _read_with_gmsh(path)
            except Exception:  # noqa: S110 - report meshio's reason, the first reader's
                pass
        lines = [*str(exc).strip().splitlines(), *" ".join(said.getvalue().split()).splitlines()]
        text = next((t for t in lines if len(t) > 3), type(exc).__name__)
        raise InvalidMesh(f"{path}: meshio cannot read it ({text})") from None


#: gmsh element type → (meshio type, node permutation to meshio's order).
_GMSH_TYPES = {2: ("triangle", None), 9: ("triangle6", None), 4: ("tetra", None)}
_GMSH_TYPES[11] = ("tetra10", [0, 1, 2, 3, 4, 5, 6, 7, 9, 8])


def _read_with_gmsh(path: Path):
    """A meshio.Mesh of a .msh read by gmsh's own API: blocks per entity, cell_sets per physical name."""
    import meshio

    gmsh = import_gmsh()
    if gmsh.isInitialized():
        raise MeshError("gmsh is already initialised in this process")
    with _openmp_threads_kept():
        initialize_gmsh(gmsh)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.open(str(path))
            tags, coords, _ = gmsh.model.mesh.getNodes()
            row = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
            row[tags.astype(np.int64)] = np.arange(len(tags))
            cells, where = [], {}
            for dim, ent in gmsh.model.getEntities():
                for etype, _, conn in zip(*gmsh.model.mesh.getElements(dim, ent), strict=True):
                    kind, perm = _GMSH_TYPES.get(int(etype), (None, None))
                    if kind is None:
                        continue
                    n = {"triangle": 3, "triangle6": 6, "tetra": 4, "tetra10": 10}[kind]
                    data = row[np.asarray(conn, dtype=np.int64).reshape(-1, n)]
                    where[(dim, ent)] = [*where.get((dim, ent), []), len(cells)]
                    cells.append((kind, data if perm is None else data[:, perm]))
            sets = {}
            for dim, ptag in gmsh.model.getPhysicalGroups():
                name = gmsh.model.getPhysicalName(dim, ptag) or f"{dim}:{ptag}"
                chosen = {
                    b
                    for e in gmsh.model.getEntitiesForPhysicalGroup(dim, ptag)
                    for b in where.get((dim, e), [])
                }
                sets[name] = [
                    np.arange(len(c[1])) if b in chosen else np.empty(0, np.int64)
                    for b, c in enumerate(cells)
                ]
        finally:
            gmsh.finalize()
    return meshio.Mesh(np.asarray(coords).reshape(-1, 3), cells, cell_sets=sets)


def _groups(m) -> dict[str, dict[int, np.ndarray]]:
    """Group name → {cell block → element indices}, from cell_sets and from tagged cell data."""
    out: dict[str, dict[int, list]] = {}
    for name, per_block in (m.cell_sets or {}).items():
        for b, idx in enumerate(per_block):
            if idx is not None and len(idx):
                out.setdefault(name, {}).setdefault(b, []).append(np.asarray(idx, dtype=np.int64))
    tags = next(
        (m.cell_data[k] for k in ("gmsh:physical", "medit:ref", "cell_tags") if k in m.cell_data), None
    )
    if tags is not None:
        for name, value in (m.field_data or {}).items():
            value = np.atleast_1d(value)
            for b, block in enumerate(m.cells):
                if len(value) > 1 and block.dim != int(value[1]):
                    continue
                idx = np.flatnonzero(np.asarray(tags[b]).ravel() == int(value[0]))
                if idx.size:
                    out.setdefault(name, {}).setdefault(b, []).append(idx)
    for key, data in m.cell_data.items():  # meshio's cell_sets_to_data: key "a-b-c", value i names the i-th
        names = key.split("-")
        if (
            len(names) > 1
            and set(names) & set(REGIONS)
            and all(np.asarray(d).dtype.kind in "iu" for d in data)
        ):
            for b, d in enumerate(data):
                d = np.asarray(d).ravel()
                for i, name in enumerate(names):
                    idx = np.flatnonzero(d == i)
                    if idx.size:
                        out.setdefault(name, {}).setdefault(b, []).append(idx)
    return {n: {b: np.unique(np.concatenate(v)) for b, v in d.items()} for n, d in out.items()}


def _cells(m, group: dict[int, np.ndarray], kinds: dict[str, int], name: str, path) -> np.ndarray:
    """Corner connectivity (file node ids) of a group's cells, which must all be of ``kinds``."""
    blocks = []
    for b, idx in sorted(group.items()):
        t = m.cells[b].type
        if t not in kinds:
            allowed = " or ".join(kinds)
            raise InvalidMesh(f"{path}: group {name!r} holds {t} cells; only {allowed} are accepted there")
        n_corner = 4 if t.startswith("tetra") else 3
        blocks.append(np.asarray(m.cells[b].data, dtype=np.int64)[idx, :n_corner])
    return np.concatenate(blocks)


def _check_curved(m, path) -> None:
    """Warn when tetra10 mid-edge nodes are off their edge midpoints (the model is straight-sided)."""
    from .elements import TET10_EDGES

    worst = 0.0
    for block in m.cells:
        if block.type == "tetra10":
            c = np.asarray(block.data, dtype=np.int64)
            p = np.asarray(m.points, dtype=float)
            a, b = p[c[:, TET10_EDGES[:, 0]]], p[c[:, TET10_EDGES[:, 1]]]
            off = np.linalg.norm(p[c[:, 4:10]] - 0.5 * (a + b), axis=2)
            worst = max(worst, float((off / np.maximum(np.linalg.norm(b - a, axis=2), 1e-300)).max()))
    if worst > CURVED_REL:
        warnings.warn(
            f"{path}: tetra10 mid-edge nodes lie up to {worst:.2g} of their edge off its midpoint; the model "
            "uses straight-sided tetrahedra on the corner nodes",
            IsjWarning,
            stacklevel=3,
        )


def _check_groups(m, groups: dict, path) -> None:
    """Refuse a mesh without a region or required face group, or with non-tetrahedral volumes."""
    wanted = (*REGIONS, *REQUIRED_FACES)
    missing = [n for n in wanted if n not in groups]
    if missing:
        found = ", ".join(sorted(groups)) or "none"
        raise InvalidMesh(
            f"{path}: no group named {missing[0]!r} (needed: {', '.join(wanted)}; found: {found})"
        )
    for block in m.cells:
        if block.type in OTHER_VOLUME_TYPES:
            raise InvalidMesh(
                f"{path}: holds {block.type} cells; only tetra and tetra10 volumes are accepted"
            )


def _region_tets(m, groups: dict, path) -> tuple[np.ndarray, np.ndarray]:
    """Corner connectivity (file node ids) of every tetrahedron and its region index (int8).

    Every tetrahedron must be in exactly one region group.
    """
    tet_blocks = [b for b, block in enumerate(m.cells) if block.type in TET_TYPES]
    owner = {b: np.full(len(m.cells[b].data), -1, dtype=np.int64) for b in tet_blocks}
    for r, name in enumerate(REGIONS):
        for b, idx in groups[name].items():
            if b not in owner:
                raise InvalidMesh(
                    f"{path}: group {name!r} holds {m.cells[b].type} cells; a region needs tetra"
                )
            twice = idx[owner[b][idx] >= 0]
            if twice.size:
                other = REGIONS[owner[b][twice[0]]]
                raise InvalidMesh(f"{path}: a tetrahedron is in two region groups, {other!r} and {name!r}")
            owner[b][idx] = r
    for b in tet_blocks:
        if (owner[b] < 0).any():
            n = int((owner[b] < 0).sum())
            raise InvalidMesh(
                f"{path}: {n} tetrahedra belong to none of the region groups {', '.join(REGIONS)}"
            )
    tets = np.concatenate([np.asarray(m.cells[b].data, dtype=np.int64)[:, :4] for b in tet_blocks])
    region = np.concatenate([owner[b] for b in tet_blocks]).astype(np.int8)
    return tets, region


def _used_nodes(m, tets, faces: dict, path, order: int, unit: str, max_bytes):
    """Points (m), tets and faces on the nodes the tetrahedra use, numbered from 0 in file order.

    The model's memory is checked on those nodes before anything large is built; a face on a
    node no tetrahedron uses, a point without three coordinates or one that is not finite is refused.
    """
    used = np.unique(tets)
    check_size(path, used.size, len(tets), order, max_bytes)  # before anything large is built
    compact = np.full(len(m.points), -1, dtype=np.int64)
    compact[used] = np.arange(used.size)
    tets = compact[tets]
    faces = dict(faces)
    for name, tri in faces.items():
        faces[name] = compact[tri]
        if (faces[name] < 0).any():
            raise InvalidMesh(f"{path}: face group {name!r} uses nodes that no tetrahedron uses")
    points = np.asarray(m.points, dtype=np.float64)[used, :3] * UNITS_M[unit]
    if points.shape[1] != 3:
        raise InvalidMesh(f"{path}: points have {points.shape[1]} coordinates; a volume mesh needs 3")
    check_finite_points(path, points, used)
    return points, tets, faces


def _cut_capsule_free(path, points, tets, region, faces: dict, topo):
    """Cut the ``capsule_free`` interface open; ``faces`` gains ``capsule_bonded``; (points, tets)."""
    bonded = topo.capsule_interface_without(faces["capsule_free"])
    if not len(bonded):
        raise InvalidMesh(
            f"{path}: face group 'capsule_free' covers all of the capsule's faces on other regions; "
            "cut open, the capsule would touch nothing"
        )
    faces["capsule_bonded"] = bonded
    return _cut_free_interface(points, tets, region, faces, REGIONS)


def read_mesh(path, order: int = 2, unit: str = "m", max_bytes: int | None = None) -> TetMesh:
    """Read, check and cut a user mesh (docs/model.md §2.11).

    Parameters
    ----------
    path : a gmsh ``.msh`` or any volume mesh meshio reads
    order : 1 or 2, the element order it will be solved at (for the memory check only)
    unit : the file's length unit, ``"m"``, ``"mm"`` or ``"um"``
    max_bytes : memory limit of the model (default :func:`fem.sizing.max_model_bytes`)

    Returns
    -------
    TetMesh
        Regions :data:`isj.design.REGIONS`, faces ``loaded``, ``clamped`` and, when given,
        ``capsule_free`` (cut open: its nodes duplicated for the capsule side), points in m.

    Raises
    ------
    InvalidMesh
        One line naming the problem: the file, a missing group, an element type, a coordinate
        that is not a finite number, an inverted or degenerate tetrahedron, duplicated nodes or a
        hanging face (a non-conforming interface), a region touching nothing, a face that is no
        face of the mesh, or the estimated memory.

    Warns
    -----
    IsjWarning
        One line with the bounding box when the mesh is far larger or smaller than a joint
        (:data:`PLAUSIBLE_EXTENT_M`: its unit is probably wrong), and for curved tetra10 edges.
    """
    path = Path(os.fspath(path))
    if order not in (1, 2):
        raise InvalidMesh(f"order = {order!r}: must be 1 or 2")
    if unit not in UNITS_M:
        raise InvalidMesh(f"unit = {unit!r}: must be one of {', '.join(UNITS_M)}")
    _precheck_size(path, order, max_bytes)
    m = _read_meshio(path)
    groups = _groups(m)
    _check_groups(m, groups, path)
    tets, region = _region_tets(m, groups, path)
    faces = {
        n: _cells(m, groups[n], TRI_TYPES, n, path) for n in (*REQUIRED_FACES, *OPTIONAL_FACES) if n in groups
    }
    points, tets, faces = _used_nodes(m, tets, faces, path, order, unit, max_bytes)
    # both warn at stacklevel 3: called from here, the warning names read_mesh's caller
    warn_implausible_size(path, points, unit)
    _check_curved(m, path)
    del m

    check_geometry(path, points, tets, region)
    topo = check_topology(path, points, tets, region, faces)
    try:
        faces = {n: _orient_faces(points, tets, f) for n, f in faces.items()}
    except MeshError as exc:
        raise InvalidMesh(f"{path}: {exc}") from None
    if "capsule_free" in faces:
        points, tets = _cut_capsule_free(path, points, tets, region, faces, topo)
    return TetMesh(points, tets, region, REGIONS, faces)


def check_finite_points(path, points: np.ndarray, node_ids: np.ndarray | None = None) -> None:
    """Refuse a node of a tetrahedron with a NaN or infinite coordinate (one line, the first such node).

    ``node_ids``: each point's index in the file (0-based; default its row), for the message.
    """
    bad = np.flatnonzero(~np.isfinite(points).all(axis=1))
    if bad.size:
        k = int(bad[0])
        node = int(k if node_ids is None else node_ids[k]) + 1
        shown = ", ".join(repr(float(v)) for v in points[k])
        raise InvalidMesh(
            f"{path}: node {node} has a coordinate that is not a finite number ({shown}); "
            f"{bad.size} such node(s) in all"
        )


def warn_implausible_size(path, points: np.ndarray, unit: str) -> bool:
    """One :class:`~isj.errors.IsjWarning` line, with the bounding box, when the mesh's largest extent
    lies outside :data:`PLAUSIBLE_EXTENT_M` (its unit is probably wrong); True if it warned."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    extent = float((hi - lo).max())
    small, large = PLAUSIBLE_EXTENT_M
    if small <= extent <= large:
        return False
    box = " x ".join(f"{v:.3g}" for v in hi - lo)
    hint = (
        "micrometres or millimetres read as metres?" if extent > large else "metres read as a smaller unit?"
    )
    warnings.warn(
        f"{path}: the mesh's bounding box is {box} m (unit {unit!r}), from {_point(lo)} to {_point(hi)}; "
        f"an incus-stapes joint spans about 1e-3 m: {hint} Give the file's unit (--mesh-unit m, mm or um)",
        IsjWarning,
        stacklevel=3,
    )
    return True


def _point(p) -> str:
    return "(" + ", ".join(f"{v:.3g}" for v in p) + ")"


# --------------------------------------------------------------------------- writing


def closed(mesh: TetMesh) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Points, tets and faces with bit-identical nodes merged (the free interface closed again).

    The first of each set of coincident nodes is kept, so a mesh cut by
    :func:`fem.mesh.mesh_pedicle_joint` (copies appended after the originals) gets its
    original numbering back.
    """
    pts = np.ascontiguousarray(mesh.points, dtype=np.float64)
    _, first, inv = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    target = first[inv.ravel()]
    keep = np.flatnonzero(target == np.arange(len(pts)))
    new_id = np.full(len(pts), -1, dtype=np.int64)
    new_id[keep] = np.arange(keep.size)
    new_id = new_id[target]
    return pts[keep], new_id[mesh.tets], {n: new_id[f] for n, f in mesh.faces.items()}


def write_mesh(mesh: TetMesh, path) -> Path:
    """Write ``mesh`` as gmsh 2.2 ASCII with physical groups per region and face, atomically.

    Physical tags: the regions 1–6 in :data:`isj.design.REGIONS` order (3-D), the faces 11,
    12, ... in ``mesh.faces`` order (2-D). Coordinates in m, 17 significant digits.
    """
    import meshio

    from isj.atomic import atomic_write

    points, tets, faces = closed(mesh)
    cells, tags, field_data = [], [], {}
    for r, name in enumerate(mesh.region_names):
        block = tets[mesh.region == r]
        cells.append(("tetra", block))
        tags.append(np.full(len(block), r + 1, dtype=np.int64))
        field_data[name] = np.array([r + 1, 3])
    for k, (name, tri) in enumerate(faces.items()):
        cells.append(("triangle", tri[:, :3]))
        tags.append(np.full(len(tri), 11 + k, dtype=np.int64))
        field_data[name] = np.array([11 + k, 2])
    out = meshio.Mesh(
        points, cells, cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags}, field_data=field_data
    )

    def write(tmp: str) -> None:
        with contextlib.redirect_stdout(io.StringIO()):
            meshio.write(tmp, out, file_format="gmsh22", binary=False, float_fmt=".16e")

    return atomic_write(path, write)
