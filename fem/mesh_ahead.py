"""Meshes made ahead in a second process while this one solves the meshes before them.

gmsh meshes on one thread (:mod:`fem.mesh`), and a study of new geometries alternates meshing
(about 2 s a geometry on the default sizes) with assembling and factoring (PARDISO on every
core). :func:`meshes_ahead` hands the meshes missing from the mesh cache to one worker process,
in the order the caller will ask for them; the caller's :func:`fem.mesh.mesh_pedicle_joint`
finds each in the cache, waiting for the worker where it is not written yet
(:func:`fem.cache.cached_mesh`). The worker makes the same mesh the caller would (the same
function, inputs and gmsh), stored and read back through the checksummed cache entry. If the
worker fails, the caller meshes what is missing itself.

The worker is ``python -m isj.fem.mesh_ahead`` (not a multiprocessing child, which would import
the caller's main script again: a notebook's or an unguarded script's code would run twice).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import subprocess
import sys
import threading
from collections.abc import Iterable, Iterator
from concurrent.futures import Future
from pathlib import Path

from isj.design import Geometry

from .cache import MESHES_AHEAD, mesh_path, resolve_cache_dir
from .mesh import _resolve, mesh_pedicle_joint

__all__ = ["meshes_ahead"]

#: The worker's line for each mesh it has written (then the entry's path).
_DONE = "meshed "


@contextlib.contextmanager
def meshes_ahead(geometries: Iterable[Geometry], resolution: float = 1.0, cache_dir=None) -> Iterator[int]:
    """Within the block, the pedicle-joint meshes of ``geometries`` (default sizes refined by
    ``resolution``) that the mesh cache lacks are made by a second process, in this order.

    Yields the number of meshes handed to it (0: every mesh is cached, or there is no cache, and
    no process is started). On leaving the block the worker is stopped; an entry it was writing
    is not left half-written (the cache's writes are atomic).
    """
    directory = resolve_cache_dir(cache_dir)
    sizes = _resolve(None, resolution)
    todo: dict[Path, Geometry] = {}
    for g in geometries:
        path = None if directory is None else mesh_path(directory, "pedicle_joint", g, sizes)
        if path is not None and not path.exists() and path not in MESHES_AHEAD:
            todo.setdefault(path, g)
    if not todo:
        yield 0
        return
    job = {"resolution": float(resolution), "directory": str(directory)}
    job["geometries"] = [dataclasses.asdict(g) for g in todo.values()]
    worker = subprocess.Popen(
        [sys.executable, "-m", "isj.fem.mesh_ahead", json.dumps(job)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    futures = {path: Future() for path in todo}
    MESHES_AHEAD.update(futures)
    reader = threading.Thread(target=_follow, args=(worker, futures), daemon=True)
    reader.start()
    try:
        yield len(todo)
    finally:
        for path in todo:
            MESHES_AHEAD.pop(path, None)
        if worker.poll() is None:
            worker.terminate()
        worker.wait()
        reader.join()


def _follow(worker: subprocess.Popen, futures: dict[Path, Future]) -> None:
    """Resolve each mesh's future as the worker reports it written; the rest fail when it ends."""
    for line in worker.stdout:
        if line.startswith(_DONE):
            future = futures.get(Path(line[len(_DONE) :].rstrip("\n")))
            if future is not None and not future.done():
                future.set_result(None)
    code = worker.wait()
    for future in futures.values():
        if not future.done():
            future.set_exception(RuntimeError(f"the meshing worker ended (exit code {code})"))


def _work(job: dict) -> None:
    """The worker: each geometry's mesh into the cache, in order, a line for each."""
    directory, resolution = job["directory"], job["resolution"]
    sizes = _resolve(None, resolution)
    for fields in job["geometries"]:
        g = Geometry(**fields)
        mesh_pedicle_joint(g, resolution, cache_dir=directory)
        print(_DONE + str(mesh_path(Path(directory), "pedicle_joint", g, sizes)), flush=True)


if __name__ == "__main__":
    _work(json.loads(sys.argv[1]))
