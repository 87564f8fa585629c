"""Meshes made ahead by a second process (fem/mesh_ahead.py): the same meshes, nothing lost."""

from __future__ import annotations

import dataclasses
import sys

import pytest

from isj.design import Geometry

RESOLUTION = 0.35  # coarse: about a second a mesh
GEOMETRIES = [dataclasses.replace(Geometry(), pedicle_x_m=Geometry().pedicle_x_m * f) for f in (0.8, 1.25)]


def test_the_worker_makes_the_meshes_this_process_would_and_the_caller_reads_them(tmp_path, monkeypatch):
    from isj.fem import cache, mesh_ahead
    from isj.fem.mesh import mesh_pedicle_joint

    made_here = []
    original = mesh_ahead.mesh_pedicle_joint.__globals__["_extract"]

    def counted(*args, **kwargs):  # meshing in this process goes through fem.mesh._extract
        made_here.append(args[2])
        return original(*args, **kwargs)

    monkeypatch.setitem(mesh_ahead.mesh_pedicle_joint.__globals__, "_extract", counted)
    with mesh_ahead.meshes_ahead(GEOMETRIES, RESOLUTION, tmp_path) as n:
        assert n == 2 and len(cache.MESHES_AHEAD) == 2
        ahead = [mesh_pedicle_joint(g, RESOLUTION, cache_dir=tmp_path) for g in GEOMETRIES]
    assert made_here == [] and cache.MESHES_AHEAD == {}  # both came from the worker, through the cache
    for g, mesh in zip(GEOMETRIES, ahead, strict=True):
        here = mesh_pedicle_joint(g, RESOLUTION, cache_dir=False)
        assert mesh.content_hash() == here.content_hash()
    with mesh_ahead.meshes_ahead(GEOMETRIES, RESOLUTION, tmp_path) as n:
        assert n == 0  # every mesh cached: no worker
    with mesh_ahead.meshes_ahead(GEOMETRIES, RESOLUTION, False) as n:
        assert n == 0  # no cache: no worker


def test_a_failed_worker_costs_a_warning_and_the_caller_meshes_itself(tmp_path, monkeypatch):
    from isj.fem import mesh_ahead
    from isj.fem.mesh import mesh_pedicle_joint

    from isj.errors import CacheWarning

    # a worker that ends at once without a mesh
    monkeypatch.setattr(sys, "executable", "/bin/false")
    with pytest.warns(CacheWarning, match="meshing ahead failed"):
        with mesh_ahead.meshes_ahead(GEOMETRIES[:1], RESOLUTION, tmp_path):
            mesh = mesh_pedicle_joint(GEOMETRIES[0], RESOLUTION, cache_dir=tmp_path)
    assert (
        mesh.content_hash() == mesh_pedicle_joint(GEOMETRIES[0], RESOLUTION, cache_dir=False).content_hash()
    )
