"""Gmsh meshes of the joint model and the cantilever (docs/model.md §2.2 and §2.6), and the mesh cache."""

import dataclasses

import numpy as np
import pytest
from isj.fem import cache as cache_mod
from isj.fem import mesh as mesh_mod
from isj.fem.cache import cache_key, default_cache_dir
from isj.fem.geometry import MeshSizes
from isj.fem.mesh import TetMesh, mesh_cantilever, mesh_pedicle_joint

from isj.design import REGIONS, Geometry
from isj.errors import CacheWarning, MeshError

G = Geometry()
SLEEVED = ("stapes", "gap", "plate")
#: Coarse sizes for the tests that only need some mesh (fast).
COARSE = MeshSizes(
    stapes_m=120e-6, gap_m=30e-6, plate_m=80e-6, pedicle_m=40e-6, incus_m=120e-6, capsule_m=30e-6
)


@pytest.fixture(scope="module")
def joint() -> TetMesh:
    return mesh_pedicle_joint(cache_dir=False)


@pytest.fixture(scope="module")
def cantilever() -> TetMesh:
    return mesh_cantilever(cache_dir=False)


def volumes(m: TetMesh) -> np.ndarray:
    p = m.points[m.tets]
    return np.linalg.det(np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]], 2)) / 6


def areas(m: TetMesh, name: str) -> np.ndarray:
    p = m.points[m.faces[name]]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def normals(m: TetMesh, name: str) -> np.ndarray:
    p = m.points[m.faces[name]]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def exact_volumes(g: Geometry) -> dict[str, float]:
    jxy = g.joint_x_m * g.joint_y_m
    t = g.capsule_thickness_m
    ring = (g.joint_x_m + 2 * t) * (g.joint_y_m + 2 * t) - jxy
    return {
        "stapes": jxy * g.stapes_height_m,
        "gap": jxy * g.gap_thickness_m,
        "plate": jxy * g.plate_thickness_m,
        "pedicle": g.pedicle_x_m * g.pedicle_y_m * g.pedicle_length_m,
        "incus": g.incus_x_m * g.incus_y_m * g.incus_length_m,
        "capsule": ring * (g.gap_thickness_m + 2 * g.capsule_reach_m),
    }


@pytest.mark.slow
def test_arrays_and_regions(joint, cantilever):
    for m in (joint, cantilever):
        assert m.points.dtype == np.float64 and m.points.shape == (m.n_nodes, 3)
        assert m.tets.dtype == np.int64 and m.tets.shape == (m.n_tets, 4)
        assert m.region.dtype == np.int8 and m.region.shape == (m.n_tets,)
        assert all(f.dtype == np.int64 and f.shape[1] == 3 for f in m.faces.values())
        # every node is used, ids are compact
        assert np.array_equal(np.unique(m.tets), np.arange(m.n_nodes))
    assert joint.region_names == REGIONS
    assert set(joint.faces) == {"clamped", "loaded", "capsule_free"}
    assert cantilever.region_names == ("pedicle",)
    assert set(cantilever.faces) == {"clamped", "loaded"}
    assert set(np.unique(joint.region)) == set(range(len(REGIONS)))


def test_all_tets_positive(joint, cantilever):
    for m in (joint, cantilever):
        assert (volumes(m) > 0).all()


def test_region_volumes_exact(joint, cantilever):
    vol = volumes(joint)
    for name, exact in exact_volumes(G).items():
        got = vol[joint.region == REGIONS.index(name)].sum()
        assert got == pytest.approx(exact, rel=1e-10), name
    exact = G.pedicle_x_m * G.pedicle_y_m * G.pedicle_length_m
    assert volumes(cantilever).sum() == pytest.approx(exact, rel=1e-10)


def test_face_areas_planes_and_outward_normals(joint, cantilever):
    g = G
    assert areas(joint, "clamped").sum() == pytest.approx(g.joint_x_m * g.joint_y_m, rel=1e-10)
    assert areas(joint, "loaded").sum() == pytest.approx(g.incus_y_m * g.incus_length_m, rel=1e-10)
    np.testing.assert_allclose(joint.points[joint.faces["clamped"], 2], 0.0, atol=1e-15)
    np.testing.assert_allclose(joint.points[joint.faces["loaded"], 0], -g.incus_x_m / 2, rtol=1e-12)
    np.testing.assert_allclose(normals(joint, "clamped")[:, 2], -1.0, atol=1e-9)
    np.testing.assert_allclose(normals(joint, "loaded")[:, 0], -1.0, atol=1e-9)
    end = g.pedicle_x_m * g.pedicle_y_m
    for name, nz in (("clamped", -1.0), ("loaded", 1.0)):
        assert areas(cantilever, name).sum() == pytest.approx(end, rel=1e-10)
        np.testing.assert_allclose(normals(cantilever, name)[:, 2], nz, atol=1e-9)
    np.testing.assert_allclose(
        cantilever.points[cantilever.faces["loaded"], 2], g.pedicle_length_m, rtol=1e-12
    )


def test_capsule_free_face(joint):
    g = G
    free_len = g.gap_thickness_m + 2 * (g.capsule_reach_m - g.capsule_bond_m)
    exact = 2 * (g.joint_x_m + g.joint_y_m) * free_len
    assert areas(joint, "capsule_free").sum() == pytest.approx(exact, rel=1e-10)
    # its triangles carry the bone-side ids
    bone = np.isin(joint.region, [REGIONS.index(n) for n in SLEEVED])
    assert np.isin(joint.faces["capsule_free"], joint.tets[bone]).all()


def test_free_interface_is_cut_and_bonded_ends_are_shared(joint):
    g = G
    z0 = g.z_gap - g.capsule_reach_m
    z1 = g.z_plate + g.capsule_reach_m
    bond = g.capsule_bond_m
    tol = 1e-6 * g.joint_x_m
    cap = joint.region == REGIONS.index("capsule")
    bone = np.isin(joint.region, [REGIONS.index(n) for n in SLEEVED])
    shared = np.intersect1d(joint.tets[cap], joint.tets[bone])
    z = joint.points[shared, 2]
    lower = (z >= z0 - tol) & (z <= z0 + bond + tol)
    upper = (z >= z1 - bond - tol) & (z <= z1 + tol)
    # nothing shared strictly inside the free zone ...
    assert (lower | upper).all(), np.sort(z[~(lower | upper)])
    # ... but both bonded zones are shared, over their whole length
    assert lower.any() and upper.any()
    assert (z < z0 + bond - tol).any() and (z > z1 - bond + tol).any()
    # every free-interface node has a capsule-side twin at the same place
    free_nodes = np.unique(joint.faces["capsule_free"])
    fz = joint.points[free_nodes, 2]
    inner = free_nodes[(fz > z0 + bond + tol) & (fz < z1 - bond - tol)]
    assert inner.size > 0
    cap_nodes = np.unique(joint.tets[cap])
    assert not np.isin(inner, cap_nodes).any()
    cap_pts = {tuple(p) for p in joint.points[cap_nodes]}
    assert all(tuple(p) in cap_pts for p in joint.points[inner])


@pytest.mark.slow
def test_deterministic(joint):
    assert mesh_pedicle_joint(cache_dir=False).content_hash() == joint.content_hash()
    a = mesh_cantilever(resolution=1.5, cache_dir=False)
    assert mesh_cantilever(resolution=1.5, cache_dir=False).content_hash() == a.content_hash()


@pytest.mark.slow
def test_resolution_refines(joint, cantilever):
    assert mesh_pedicle_joint(resolution=2, cache_dir=False).n_tets > joint.n_tets
    assert mesh_cantilever(resolution=2, cache_dir=False).n_tets > cantilever.n_tets
    # resolution multiplies the sizes' own resolution
    a = mesh_cantilever(sizes=COARSE.refined(2.0), cache_dir=False)
    b = mesh_cantilever(sizes=COARSE, resolution=2.0, cache_dir=False)
    assert a.content_hash() == b.content_hash()


@pytest.mark.slow
def test_other_geometry(cantilever):
    g = G.replace(pedicle_x_m=80e-6, capsule_bond_m=40e-6, capsule_thickness_m=20e-6)
    m = mesh_pedicle_joint(g, sizes=COARSE, cache_dir=False)
    vol = volumes(m)
    assert (vol > 0).all()
    for name, exact in exact_volumes(g).items():
        assert vol[m.region == REGIONS.index(name)].sum() == pytest.approx(exact, rel=1e-10)


def test_cache_round_trip(tmp_path, monkeypatch):
    first = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    files = list(tmp_path.glob("*.npz"))
    assert len(files) == 1 and not list(tmp_path.glob("*.tmp"))

    def no_gmsh(*args, **kwargs):
        raise AssertionError("gmsh ran although the mesh was cached")

    monkeypatch.setattr(mesh_mod, "_gmsh_mesh", no_gmsh)
    again = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    assert again.content_hash() == first.content_hash()
    for a, b in ((again.points, first.points), (again.tets, first.tets)):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert again.region_names == first.region_names


def test_corrupt_cache_entry_warns_and_recomputes(tmp_path):
    first = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    (path,) = tmp_path.glob("*.npz")
    path.write_bytes(path.read_bytes()[:200])
    with pytest.warns(CacheWarning, match="unreadable"):
        again = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    assert again.content_hash() == first.content_hash()
    # rewritten: a third read is silent and identical
    assert mesh_cantilever(sizes=COARSE, cache_dir=tmp_path).content_hash() == first.content_hash()


def test_tampered_cache_entry_is_not_used(tmp_path):
    first = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    (path,) = tmp_path.glob("*.npz")
    with np.load(path) as z:
        arrays = dict(z)
    arrays["points"] = arrays["points"] * 1.01
    np.savez(path, **arrays)
    with pytest.warns(CacheWarning):
        again = mesh_cantilever(sizes=COARSE, cache_dir=tmp_path)
    assert again.content_hash() == first.content_hash()


def test_cache_key_and_default_dir(tmp_path, monkeypatch):
    base = cache_key("cantilever", G, COARSE)
    assert base == cache_key("cantilever", Geometry(), dataclasses.replace(COARSE))
    assert base != cache_key("pedicle_joint", G, COARSE)
    assert base != cache_key("cantilever", G.replace(pedicle_x_m=50e-6), COARSE)
    assert base != cache_key("cantilever", G, COARSE.refined(2))
    monkeypatch.setattr(cache_mod, "MESH_FORMAT_VERSION", cache_mod.MESH_FORMAT_VERSION + 1)
    assert base != cache_key("cantilever", G, COARSE)
    monkeypatch.setenv("ISJ_CACHE_DIR", str(tmp_path / "c"))
    assert default_cache_dir() == tmp_path / "c"
    monkeypatch.delenv("ISJ_CACHE_DIR")
    assert default_cache_dir().parts[-3:] == (".cache", "isj", "meshes")


def test_gmsh_failure_raises_mesh_error(monkeypatch):
    import gmsh

    def broken(geometry, sizes):
        gmsh.model.mesh.field.setNumber(12345, "VIn", 1.0)  # no such field

    monkeypatch.setattr(mesh_mod, "build_cantilever", broken)
    with pytest.raises(MeshError) as info:
        mesh_cantilever(cache_dir=False)
    assert "\n" not in str(info.value)
    assert not gmsh.isInitialized()


def test_invalid_arguments():
    with pytest.raises(ValueError):
        mesh_cantilever(resolution=0, cache_dir=False)
    with pytest.raises(ValueError):
        MeshSizes(gap_m=-1e-6)


def test_capsule_free_normals_point_into_the_capsule(joint):
    g = G
    p = joint.points[joint.faces["capsule_free"]].mean(axis=1)
    n = normals(joint, "capsule_free")
    # each triangle lies on a side of the joint section; its normal points away from the axis
    on_x = np.isclose(np.abs(p[:, 0]), g.joint_x_m / 2, rtol=1e-9)
    on_y = np.isclose(np.abs(p[:, 1]), g.joint_y_m / 2, rtol=1e-9)
    assert (on_x | on_y).all()
    np.testing.assert_allclose(n[on_x, 0], np.sign(p[on_x, 0]), atol=1e-9)
    np.testing.assert_allclose(n[on_y, 1], np.sign(p[on_y, 1]), atol=1e-9)
