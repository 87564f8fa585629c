"""Linear tetrahedral meshes of the pedicle-and-joint model and the pedicle cantilever.

:func:`mesh_pedicle_joint` and :func:`mesh_cantilever` run gmsh (deterministically:
one thread, fixed algorithm and seed, so equal parameters give byte-identical
meshes), extract linear tetrahedra, and return a :class:`TetMesh` in metres.
For the joint model the capsule's free interface (docs/model.md §2.2) is cut open after
meshing by duplicating its nodes. Results are cached on disk (:mod:`fem.cache`).
"""

from __future__ import annotations

import ctypes
import os
from contextlib import contextmanager
from os import PathLike

import numpy as np

from isj.design import REGIONS, Geometry
from isj.errors import MeshError

from .cache import cached_mesh
from .geometry import GMSH_UNIT_M, MeshSizes, build_cantilever, build_pedicle_joint
from .tetmesh import TetMesh

#: Gmsh element type of the 4-node tetrahedron and the 3-node triangle.
_TET4, _TRI3 = 4, 2

#: Bone regions the capsule touches; the free interface is cut between these and the capsule.
_SLEEVED = ("stapes", "gap", "plate")


# --------------------------------------------------------------------------- gmsh run


def _configure(gmsh) -> None:
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.Verbosity", 2)
    # Determinism: everything on one thread, fixed seed and perturbation. HXT
    # (3-D) is reproducible on one thread and, unlike the classic Delaunay
    # mesher, leaves no flat slivers in the thin gap and capsule layers when
    # their element size approaches their thickness.
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads1D", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads2D", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads3D", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay surfaces
    gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT
    gmsh.option.setNumber("Mesh.RandomFactor", 1e-9)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)
    gmsh.option.setNumber("Mesh.ElementOrder", 1)
    gmsh.option.setNumber("Mesh.Optimize", 1)


def _elements(gmsh, dim: int, entities: list[int], etype: int) -> np.ndarray:
    """Connectivity (gmsh node tags) of all elements of ``etype`` on the given entities."""
    nn = 4 if etype == _TET4 else 3
    blocks = []
    for e in entities:
        types, _, enodes = gmsh.model.mesh.getElements(dim, e)
        for t, conn in zip(types, enodes, strict=True):
            if t != etype:
                raise MeshError(f"unexpected gmsh element type {t} on entity {dim}:{e}")
            blocks.append(np.asarray(conn, dtype=np.int64).reshape(-1, nn))
    return np.concatenate(blocks) if blocks else np.empty((0, nn), np.int64)


#: Debian packages that gmsh's PyPI wheel needs on a headless machine.
GMSH_SYSTEM_PACKAGES = "libglu1-mesa libgl1 libxrender1 libxcursor1 libxft2 libxinerama1 libgomp1"


def import_gmsh():
    """Import gmsh, or raise MeshError saying which system libraries are missing."""
    try:
        import gmsh
    except (ImportError, OSError) as exc:
        raise MeshError(
            f"gmsh cannot be loaded ({str(exc).splitlines()[0]}); on Debian run: "
            f"apt-get install --no-install-recommends {GMSH_SYSTEM_PACKAGES}"
        ) from None
    return gmsh


def initialize_gmsh(gmsh) -> None:
    """``gmsh.initialize`` without config files, SIGINT handler or a file in the user's home.

    gmsh's first initialisation in a process reads FLTK's options, and FLTK then creates
    ``$HOME/.fltk/fltk.org/fltk.prefs``. For that call ``HOME`` and ``XDG_CONFIG_HOME`` point
    at a temporary folder, removed afterwards, and are then restored: nothing is written
    beyond the caches and the outputs. ``interruptible=False``: gmsh's SIGINT handler can only
    be installed from the main thread.
    """
    import tempfile

    saved = {k: os.environ.get(k) for k in ("HOME", "XDG_CONFIG_HOME")}
    with tempfile.TemporaryDirectory(prefix="isj-gmsh-home-") as home:
        os.environ.update(HOME=home, XDG_CONFIG_HOME=home)
        try:
            gmsh.initialize(readConfigFiles=False, interruptible=False)
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v


#: Names under which gmsh's OpenMP runtime is loaded (Linux, macOS).
_OPENMP_LIBS = ("libgomp.so.1", "libgomp.1.dylib", "libomp.dylib")


@contextmanager
def _openmp_threads_kept():
    """Restore the calling thread's OpenMP thread count after a gmsh session.

    gmsh applies ``General.NumThreads`` (one, for determinism) with
    ``omp_set_num_threads`` and leaves it so. MKL's PARDISO shares that runtime
    when gmsh was loaded first; a factorization analysed with two threads then
    crashed (SIGSEGV) when factored again with one, and results depended on
    whether a mesh came from the cache. :mod:`fem.solvers` pins PARDISO's own
    count; this puts the process's count back for everything else. Only a
    runtime that is already loaded is touched (RTLD_NOLOAD).
    """
    lib = None
    for name in _OPENMP_LIBS:
        try:
            lib = ctypes.CDLL(name, mode=os.RTLD_NOLOAD | os.RTLD_LAZY)
            break
        except (OSError, AttributeError):  # not loaded, or no RTLD_NOLOAD (Windows)
            continue
    before = int(lib.omp_get_max_threads()) if lib is not None else None
    try:
        yield
    finally:
        if before is not None:
            lib.omp_set_num_threads(ctypes.c_int(before))


def _gmsh_mesh(kind, builder, geometry, sizes, region_names, face_names):
    """Build and mesh with gmsh; return (node tags, coordinates µm, tets per region, faces)."""
    gmsh = import_gmsh()

    if gmsh.isInitialized():
        # Our options are global: running inside someone else's session would change theirs.
        raise MeshError("gmsh is already initialised in this process; finalize it first")
    with _openmp_threads_kept():
        return _gmsh_session(gmsh, kind, builder, geometry, sizes, region_names, face_names)


def _gmsh_session(gmsh, kind, builder, geometry, sizes, region_names, face_names):
    initialize_gmsh(gmsh)
    try:
        _configure(gmsh)
        gmsh.model.add(f"isj_{kind}")
        try:
            tags = builder(geometry, sizes)
            gmsh.model.mesh.generate(3)
        except Exception as exc:  # gmsh raises plain Exception
            lines = str(exc).strip().splitlines() or [type(exc).__name__]
            raise MeshError(f"gmsh failed on the {kind} model: {lines[-1]}") from exc
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        tets = [_elements(gmsh, 3, tags[name], _TET4) for name in region_names]
        faces = {name: _elements(gmsh, 2, tags[name], _TRI3) for name in face_names}
    finally:
        gmsh.finalize()
    return np.asarray(node_tags, dtype=np.int64), np.asarray(coords).reshape(-1, 3), tets, faces


def _extract(kind, builder, geometry, sizes, region_names, face_names):
    """Mesh with gmsh and return compact arrays (points m, tets, region, faces)."""
    node_tags, coords, tet_blocks, raw_faces = _gmsh_mesh(
        kind, builder, geometry, sizes, region_names, face_names
    )
    counts = [len(b) for b in tet_blocks]
    if min(counts) == 0:
        empty = [n for n, c in zip(region_names, counts, strict=True) if c == 0]
        raise MeshError(f"gmsh produced no tetrahedra in region(s) {', '.join(empty)}")
    tets = np.concatenate(tet_blocks)
    region = np.repeat(np.arange(len(region_names), dtype=np.int8), counts)

    # Keep only nodes used by tetrahedra, numbered in increasing gmsh tag order.
    row = np.full(int(node_tags.max()) + 1, -1, dtype=np.int64)
    row[node_tags] = np.arange(len(node_tags))
    used = np.unique(tets)
    points = coords[row[used]] * GMSH_UNIT_M
    compact = np.full(row.shape, -1, dtype=np.int64)
    compact[used] = np.arange(len(used))
    tets = compact[tets]
    faces = {n: compact[f] for n, f in raw_faces.items()}
    if any((f < 0).any() for f in faces.values()):
        raise MeshError("a boundary triangle uses a node that no tetrahedron uses")
    tets = _orient(points, tets)
    return points, tets, region, {n: _orient_faces(points, tets, f) for n, f in faces.items()}


def _orient(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Swap nodes 2 and 3 of negatively oriented tets; raise on degenerate ones."""
    p = points[tets]
    det = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    scale = np.ptp(points, axis=0).max() ** 3
    if (np.abs(det) <= 1e-14 * scale).any():
        raise MeshError(f"{int((np.abs(det) <= 1e-14 * scale).sum())} degenerate tetrahedra")
    tets = tets.copy()
    neg = det < 0
    tets[neg, 2], tets[neg, 3] = tets[neg, 3], tets[neg, 2].copy()
    return tets


def _orient_faces(points: np.ndarray, tets: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Order each triangle so that (p1 − p0) × (p2 − p0) points out of a tet it bounds.

    On the outer boundary that is the outward normal. Each triangle must be a
    face of some tetrahedron (checked). For an interior interface the tet found
    first in id order decides, so call this before the free interface is cut.
    """
    n = np.int64(len(points))
    if n >= 2_000_000:  # the int64 face keys below would overflow
        raise MeshError(f"{n} nodes: too many for face orientation (limit 2e6)")

    def key_of(f: np.ndarray) -> np.ndarray:
        return (f[:, 0] * n + f[:, 1]) * n + f[:, 2]

    local = np.array([(1, 2, 3, 0), (0, 2, 3, 1), (0, 1, 3, 2), (0, 1, 2, 3)])
    tf = tets[:, local].reshape(-1, 4)  # (4·n_tets, [3 face nodes, opposite node])
    tet_keys = key_of(np.sort(tf[:, :3], axis=1))
    order = np.argsort(tet_keys, kind="stable")
    keys = key_of(np.sort(tri, axis=1))
    pos = np.searchsorted(tet_keys[order], keys)
    pos = np.minimum(pos, len(order) - 1)
    hit = order[pos]
    if (tet_keys[hit] != keys).any():
        raise MeshError("a boundary triangle is not a face of any tetrahedron")
    opposite = tf[hit, 3]
    p = points
    normal = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
    inward = np.einsum("ij,ij->i", normal, p[opposite] - p[tri[:, 0]]) > 0
    tri = tri.copy()
    tri[inward, 1], tri[inward, 2] = tri[inward, 2], tri[inward, 1].copy()
    return tri


def _cut_free_interface(points, tets, region, faces, region_names):
    """Duplicate the free-interface nodes and give the copies to the capsule tets.

    Free nodes are the nodes of the ``capsule_free`` triangles that are not also
    on a capsule face bonded to bone (those lie on the two lines bounding the
    free zone and must stay shared). Capsule tets are rewired to the copies, so
    no capsule tet shares a node with stapes/gap/plate over the free zone.
    """
    bonded = faces.pop("capsule_bonded")
    free = np.setdiff1d(np.unique(faces["capsule_free"]), np.unique(bonded))
    n = len(points)
    new_id = np.arange(n, dtype=np.int64)
    new_id[free] = n + np.arange(len(free))
    tets = tets.copy()
    cap = region == region_names.index("capsule")
    tets[cap] = new_id[tets[cap]]
    points = np.concatenate([points, points[free]])
    return points, tets


# --------------------------------------------------------------------------- public API


def _resolve(sizes: MeshSizes | None, resolution: float) -> MeshSizes:
    if not (isinstance(resolution, int | float) and 0 < resolution < float("inf")):
        raise ValueError(f"resolution = {resolution!r}: must be a finite number > 0")
    return (sizes or MeshSizes()).refined(float(resolution))


#: Default geometry (a frozen dataclass, so sharing one instance is safe).
DEFAULT_GEOMETRY = Geometry()


def mesh_pedicle_joint(
    geometry: Geometry = DEFAULT_GEOMETRY,
    resolution: float = 1.0,
    sizes: MeshSizes | None = None,
    cache_dir: str | PathLike | bool | None = None,
) -> TetMesh:
    """Linear tetrahedral mesh of the pedicle-and-joint model (docs/model.md §2.2).

    Parameters
    ----------
    geometry : Geometry
        Dimensions (m).
    resolution : float
        Refinement factor R multiplying ``sizes.resolution``: every element size
        is divided by it (R = 2 → half the size, ≈ 8× the tetrahedra).
    sizes : MeshSizes, optional
        Element sizes per region (m); defaults to :class:`MeshSizes()`.
    cache_dir : path, None or False
        Mesh cache directory; None → ``$ISJ_CACHE_DIR`` or ``~/.cache/isj/meshes``;
        False → no cache.

    Returns
    -------
    TetMesh
        Regions :data:`isj.design.REGIONS`; faces ``"clamped"`` (z = 0),
        ``"loaded"`` (incus −x face), ``"capsule_free"``. The free capsule
        interface is cut: its nodes are duplicated for the capsule side.

    Raises
    ------
    MeshError
        If gmsh fails.
    """
    sizes = _resolve(sizes, resolution)

    def compute() -> TetMesh:
        points, tets, region, faces = _extract(
            "pedicle_joint",
            build_pedicle_joint,
            geometry,
            sizes,
            REGIONS,
            ("clamped", "loaded", "capsule_free", "capsule_bonded"),
        )
        points, tets = _cut_free_interface(points, tets, region, faces, REGIONS)
        return TetMesh(points, tets, region, REGIONS, faces)

    return cached_mesh("pedicle_joint", geometry, sizes, cache_dir, compute)


def mesh_cantilever(
    geometry: Geometry = DEFAULT_GEOMETRY,
    resolution: float = 1.0,
    sizes: MeshSizes | None = None,
    cache_dir: str | PathLike | bool | None = None,
) -> TetMesh:
    """Linear tetrahedral mesh of the pedicle alone as a cantilever (docs/model.md §2.6).

    The box ``pedicle_x_m`` × ``pedicle_y_m`` × ``pedicle_length_m``, z from 0 to
    L, element size ``sizes.pedicle_m / R``. Parameters as for
    :func:`mesh_pedicle_joint`.

    Returns
    -------
    TetMesh
        Region ``("pedicle",)``; faces ``"clamped"`` (z = 0) and ``"loaded"`` (z = L).
    """
    sizes = _resolve(sizes, resolution)

    def compute() -> TetMesh:
        points, tets, region, faces = _extract(
            "cantilever", build_cantilever, geometry, sizes, ("pedicle",), ("clamped", "loaded")
        )
        return TetMesh(points, tets, region, ("pedicle",), faces)

    return cached_mesh("cantilever", geometry, sizes, cache_dir, compute)
