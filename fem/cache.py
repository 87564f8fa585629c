"""Disk cache of meshes, keyed by what the mesh depends on, and of solver orderings.

Key: sha256 of the canonical JSON of (kind, geometry fields, mesh sizes, resolution,
:data:`MESH_FORMAT_VERSION`, and :func:`isj.results_version.versions` of the ``mesh``
family: the meshing results version and gmsh's version). The meshing code's text is
not part of it: a refactor of :mod:`isj.fem.mesh` or :mod:`isj.fem.geometry` keeps every
entry, a change of the meshes they make bumps the ``mesh`` version
(docs/developer/cache-keys.md).
Entries are ``.npz`` files (no pickles) with a checksum of their arrays
(:mod:`isj.cachefile`), written atomically. An entry that cannot be read, fails
its checksum or whose mesh content hash does not match is reported with one
:class:`~isj.errors.CorruptCacheEntry` warning, deleted and recomputed, never used.

PARDISO's fill-reducing ordering (450 kB for the default mesh) is kept beside
the meshes the same way, keyed by the pattern it was made for
(:func:`fem.solvers.ordering_key`): a later process skips METIS, about a third
of PARDISO's analysis, and gets the same bits (docs/performance.md §8.2).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import warnings
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from isj.cachefile import DamagedEntry, discard, read_npz_entry, write_npz_entry
from isj.caches import MESH_CACHE_ENV, mesh_cache_dir
from isj.errors import CacheWarning
from isj.results_version import versions

from .tetmesh import TetMesh

if TYPE_CHECKING:
    from isj.design import Geometry

    from .geometry import MeshSizes

#: Bump whenever the stored layout of an entry changes (a change of the meshes themselves bumps
#: the ``mesh`` family of :mod:`isj.results_version`).
MESH_FORMAT_VERSION = 1

#: Environment variable overriding the default cache directory.
CACHE_ENV = MESH_CACHE_ENV

#: ``$ISJ_CACHE_DIR`` if set, else ``~/.cache/isj/meshes`` (one definition, in :mod:`isj.caches`).
default_cache_dir = mesh_cache_dir


def resolve_cache_dir(cache_dir: str | os.PathLike | bool | None) -> Path | None:
    """None → default directory; False → None (cache disabled); a path → that path."""
    if cache_dir is False:
        return None
    if cache_dir is None or cache_dir is True:
        return default_cache_dir()
    return Path(cache_dir)


def cache_key(kind: str, geometry: Geometry, sizes: MeshSizes) -> str:
    """sha256 (hex) of the canonical JSON of everything the mesh depends on (module docstring)."""
    payload = {
        "kind": kind,
        "geometry": dataclasses.asdict(geometry),
        "sizes": dataclasses.asdict(sizes),
        "resolution": sizes.resolution,
        "format": MESH_FORMAT_VERSION,
        "versions": versions("mesh"),
    }
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


_FACE_PREFIX = "face__"


def save_mesh(mesh: TetMesh, path: Path) -> None:
    """Write ``mesh`` to ``path`` (.npz, with a checksum) atomically."""
    arrays = {
        "points": mesh.points,
        "tets": mesh.tets,
        "region": mesh.region,
        "region_names": np.array(mesh.region_names, dtype=str),
        "content_hash": np.array(mesh.content_hash()),
        "format": np.array(MESH_FORMAT_VERSION),
    }
    arrays.update({_FACE_PREFIX + k: v for k, v in mesh.faces.items()})
    write_npz_entry(path, arrays)


def load_mesh(path: Path) -> TetMesh:
    """Read a mesh written by :func:`save_mesh`.

    Raises
    ------
    DamagedEntry
        Unreadable, failed checksum, other format, or a mesh whose content hash differs.
    """
    z, _ = read_npz_entry(path)
    try:
        if int(z["format"]) != MESH_FORMAT_VERSION:
            raise DamagedEntry(f"format {int(z['format'])} != {MESH_FORMAT_VERSION}")
        faces = {k[len(_FACE_PREFIX) :]: z[k] for k in z if k.startswith(_FACE_PREFIX)}
        mesh = TetMesh(
            points=z["points"],
            tets=z["tets"],
            region=z["region"],
            region_names=tuple(str(s) for s in z["region_names"]),
            faces=faces,
        )
        stored = str(z["content_hash"])
    except (KeyError, TypeError, ValueError) as exc:  # arrays missing or of the wrong kind
        raise DamagedEntry(f"{type(exc).__name__}: {exc}") from exc
    if mesh.content_hash() != stored:
        raise DamagedEntry("content hash does not match the stored arrays")
    return mesh


def mesh_path(directory: Path, kind: str, geometry: Geometry, sizes: MeshSizes) -> Path:
    """The cache entry of the mesh for (kind, geometry, sizes) in ``directory``."""
    return directory / f"{kind}-{cache_key(kind, geometry, sizes)[:32]}.npz"


#: Meshes a second process is making for this one (:func:`fem.mesh_ahead.meshes_ahead`): the
#: entry's path → the future of its making.
MESHES_AHEAD: dict[Path, Future] = {}


def _wait_for_mesh_ahead(path: Path) -> None:
    """Wait for the second process's mesh at ``path``, if it is making one; if it failed, this
    process makes the mesh itself (the entry is then missing)."""
    future = MESHES_AHEAD.pop(path, None)
    if future is None:
        return
    try:
        future.result()
    except Exception as exc:  # a broken or cancelled worker: meshed here instead, nothing lost
        reason = f"{type(exc).__name__}: {exc}"
        warnings.warn(f"meshing ahead failed ({reason}); meshing here", CacheWarning, stacklevel=4)


def cached_mesh(
    kind: str,
    geometry: Geometry,
    sizes: MeshSizes,
    cache_dir: str | os.PathLike | bool | None,
    compute: Callable[[], TetMesh],
) -> TetMesh:
    """Return the cached mesh for (kind, geometry, sizes), computing and storing it if needed.

    A cache directory that cannot be written only costs a warning: the mesh is
    still returned.
    """
    directory = resolve_cache_dir(cache_dir)
    if directory is None:
        return compute()
    path = mesh_path(directory, kind, geometry, sizes)
    _wait_for_mesh_ahead(path)
    if path.exists():
        try:
            return load_mesh(path)
        except DamagedEntry as exc:
            discard(path, "mesh", str(exc), stacklevel=3)
    mesh = compute()
    try:
        save_mesh(mesh, path)
    except OSError as exc:
        warnings.warn(f"could not write mesh cache entry {path}: {exc}", CacheWarning, stacklevel=3)
    return mesh


# --------------------------------------------------------------------------- solver orderings

#: Bump whenever the stored ordering's layout changes.
ORDERING_FORMAT_VERSION = 1


def ordering_path(directory: Path, key: str) -> Path:
    """The entry of the fill-reducing ordering with key ``key`` (:func:`fem.solvers.ordering_key`)."""
    return directory / f"ordering-{key[:32]}.npz"


def load_ordering(directory: Path | None, key: str, n: int) -> np.ndarray | None:
    """The cached 1-based ordering of ``n`` unknowns under ``key``, or None if there is none.

    An entry that fails its checksum, was made for another key or is not a
    permutation of 1..n (PARDISO would crash on it) is reported with one
    :class:`~isj.errors.CorruptCacheEntry` warning, deleted, and None returned.
    """
    if directory is None:
        return None
    path = ordering_path(directory, key)
    if not path.exists():
        return None
    try:
        z, _ = read_npz_entry(path)
        try:
            if int(z["format"]) != ORDERING_FORMAT_VERSION or str(z["key"]) != key:
                raise DamagedEntry("made for another key or format")
            perm = np.asarray(z["perm"])
        except (KeyError, TypeError, ValueError) as exc:
            raise DamagedEntry(f"{type(exc).__name__}: {exc}") from exc
        if (
            perm.dtype != np.int32
            or perm.shape != (n,)
            or not np.array_equal(np.sort(perm), np.arange(1, n + 1))
        ):
            raise DamagedEntry(f"not a permutation of 1..{n}")
    except DamagedEntry as exc:
        discard(path, "solver ordering", str(exc), stacklevel=3)
        return None
    return perm


def store_ordering(directory: Path | None, key: str, perm: np.ndarray) -> None:
    """Write a 1-based ordering under ``key`` atomically; a cache that cannot be written costs a warning."""
    if directory is None:
        return
    path = ordering_path(directory, key)
    arrays = {
        "perm": np.asarray(perm, dtype=np.int32),
        "key": np.array(key),
        "format": np.array(ORDERING_FORMAT_VERSION),
    }
    try:
        write_npz_entry(path, arrays)
    except OSError as exc:
        warnings.warn(
            f"could not write solver ordering cache entry {path}: {exc}", CacheWarning, stacklevel=3
        )
