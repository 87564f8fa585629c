"""Shared fixtures: a private mesh cache and one coarse model reused across tests."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def _private_mesh_cache(tmp_path_factory):
    """Keep the tests' meshes out of the user's cache (and start from an empty one)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("ISJ_CACHE_DIR", str(tmp_path_factory.mktemp("mesh-cache")))
    yield
    mp.undo()


@pytest.fixture(scope="session")
def coarse_model():
    """A coarse P2 model (seconds to build): for properties that hold on any mesh."""
    pytest.importorskip("gmsh")
    from isj.fem.model import PedicleJointModel

    return PedicleJointModel(order=2, resolution=0.35)
