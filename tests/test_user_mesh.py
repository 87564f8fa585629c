"""The user's own mesh (docs/model.md §2.11): `isj fem mesh --msh` then `isj fem solve --mesh`
gives the built-in α and β; a bad mesh is one line naming the problem and exit code 2."""

import json
import warnings

import meshio
import numpy as np
import pytest
from isj.fem.mesh import mesh_pedicle_joint
from isj.fem.user_mesh import closed, read_mesh, write_mesh

from isj.cli import main
from isj.design import REGIONS
from isj.errors import InvalidMesh

COARSE = ["--resolution", "0.35"]
ANGLES = ("alpha_rad", "beta_rad", "alpha_ls_rad", "beta_ls_rad")


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def joint():
    return mesh_pedicle_joint(resolution=0.35)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """`isj fem mesh --msh --points-out` at the coarse resolution."""
    d = tmp_path_factory.mktemp("user-mesh")
    msh, toml = d / "joint.msh", d / "joint.toml"
    assert main(["fem", "mesh", "--order", "1", *COARSE, "--msh", str(msh), "--points-out", str(toml)]) == 0
    return msh, toml


def write_arrays(path, points, tets, region, faces, names=REGIONS, file_format="gmsh22"):
    """A gmsh 2.2 file (or another meshio format) of raw arrays, one physical group per name."""
    cells, tags, field_data = [], [], {}
    for r, name in enumerate(REGIONS):
        cells.append(("tetra", tets[region == r]))
        tags.append(np.full(int((region == r).sum()), r + 1))
        if name in names:
            field_data[name] = np.array([r + 1, 3])
    for k, (name, tri) in enumerate(faces.items()):
        cells.append(("triangle", tri))
        tags.append(np.full(len(tri), 11 + k))
        if name in names or name not in REGIONS:
            field_data[name] = np.array([11 + k, 2])
    if file_format == "gmsh22":
        m = meshio.Mesh(
            points, cells, cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags}, field_data=field_data
        )
        meshio.write(path, m, file_format="gmsh22", binary=False)
    else:  # named cell sets
        sets = {}
        for b, name in enumerate([*REGIONS, *faces]):
            if name in field_data:
                sets[name] = [
                    np.arange(len(cells[b][1])) if i == b else np.empty(0, int) for i in range(len(cells))
                ]
        meshio.write(path, meshio.Mesh(points, cells, cell_sets=sets), file_format=file_format)
    return path


def uncut(joint):
    points, tets, faces = closed(joint)
    return points, tets.copy(), joint.region, dict(faces)


@pytest.mark.slow
@pytest.mark.parametrize("order", [1, 2])
def test_round_trip_gives_the_built_in_alpha_and_beta(capsys, files, order):
    msh, toml = files
    _, out, _ = run(capsys, ["fem", "solve", "--json", "--order", str(order), *COARSE])
    built_in = json.loads(out)
    code, out, err = run(
        capsys, ["fem", "solve", "--json", "--order", str(order), "--mesh", str(msh), "--points", str(toml)]
    )
    assert code == 0, err
    pairs = json.loads(out)
    _, out, _ = run(capsys, ["fem", "solve", "--json", "--order", str(order), "--mesh", str(msh)])
    ls = json.loads(out)
    assert pairs["angle_definition"] == "point pairs" and ls["angle_definition"] == "least squares"
    for key in ANGLES:
        assert pairs[key] == pytest.approx(built_in[key], rel=1e-9, abs=0)
    assert ls["alpha_rad"] == pytest.approx(built_in["alpha_ls_rad"], rel=1e-9, abs=0)
    assert ls["beta_rad"] == pytest.approx(built_in["beta_ls_rad"], rel=1e-9, abs=0)
    for region, e in built_in["strain_energy_j"].items():
        assert pairs["strain_energy_j"][region] == pytest.approx(e, rel=1e-9)
    assert pairs["n_dofs"] == built_in["n_dofs"] and pairs["mesh_hash"] == built_in["mesh_hash"]


def test_read_back_is_the_same_mesh(joint, tmp_path):
    back = read_mesh(write_mesh(joint, tmp_path / "j.msh"))
    assert back.content_hash() == joint.content_hash()
    assert np.array_equal(back.points, joint.points)  # bit for bit


def test_named_cell_sets_of_another_format(joint, tmp_path):
    p, t, r, f = uncut(joint)
    back = read_mesh(write_arrays(tmp_path / "j.vtu", p, t, r, f, file_format="vtu"), order=1)
    assert np.array_equal(back.tets, joint.tets) and np.array_equal(back.points, joint.points)


def test_strain_energy_per_region_sums_to_half_the_work(files):
    from isj.fem.user_model import UserMeshModel, read_points

    from isj.design import Materials

    msh, toml = files
    model = UserMeshModel(read_mesh(msh), order=1, points=read_points(toml))
    res = model.static(Materials(), 28.5)
    work = 0.5 * float(model.unit_load @ res.displacement_m.ravel()) * 28.5
    assert sum(res.strain_energy_j.values()) == pytest.approx(work, rel=1e-9)


def refused(capsys, path, *extra):
    code, out, err = run(capsys, ["fem", "solve", "--order", "1", "--mesh", str(path), *extra])
    assert code == 2 and out == "" and err.count("\n") == 1, (code, out, err)
    return err


def test_missing_group_is_named(capsys, joint, tmp_path):
    p, t, r, f = uncut(joint)
    err = refused(capsys, write_arrays(tmp_path / "m.msh", p, t, r, f, names=set(REGIONS) - {"gap"}))
    assert "no group named 'gap'" in err
    del f["loaded"]
    err = refused(capsys, write_arrays(tmp_path / "m2.msh", p, t, r, f))
    assert "no group named 'loaded'" in err


def test_inverted_element_is_named(capsys, joint, tmp_path):
    p, t, r, f = uncut(joint)
    k = int(np.flatnonzero(r == REGIONS.index("plate"))[5])
    t[k, [2, 3]] = t[k, [3, 2]]
    err = refused(capsys, write_arrays(tmp_path / "inv.msh", p, t, r, f))
    assert f"tetrahedron {k + 1} (region plate" in err and "inverted" in err and "volume -" in err


def test_degenerate_element_is_named(capsys, joint, tmp_path):
    p, t, r, f = uncut(joint)
    k = int(np.flatnonzero(r == REGIONS.index("pedicle"))[0])
    t[k, 3] = t[k, 2]
    err = refused(capsys, write_arrays(tmp_path / "flat.msh", p, t, r, f))
    assert f"tetrahedron {k + 1}" in err and "degenerate" in err


def _own_nodes(p, t, r, name, shift=(0.0, 0.0, 0.0)):
    """Give region ``name`` its own copies of its nodes (moved by ``shift``)."""
    sel = r == REGIONS.index(name)
    nodes = np.unique(t[sel])
    new = np.full(len(p), -1)
    new[nodes] = len(p) + np.arange(len(nodes))
    t = t.copy()
    t[sel] = new[t[sel]]
    return np.vstack([p, p[nodes] + shift]), t


def test_non_conforming_interface(capsys, joint, tmp_path):
    p, t, r, f = uncut(joint)
    p2, t2 = _own_nodes(p, t, r, "pedicle")
    err = refused(capsys, write_arrays(tmp_path / "dup.msh", p2, t2, r, f))
    assert "non-conforming interface" in err and "pedicle" in err


def test_face_split_on_one_side_only(capsys, joint, tmp_path):
    """A pedicle tetrahedron on the incus split at its face's centroid: a hanging node."""
    p, t, r, f = uncut(joint)
    ped, inc = REGIONS.index("pedicle"), REGIONS.index("incus")
    inc_faces = {
        tuple(sorted(t[e][list(s)]))
        for e in np.flatnonzero(r == inc)
        for s in ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2))
    }
    k, face = next(
        (e, s)
        for e in np.flatnonzero(r == ped)
        for s in ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2))
        if tuple(sorted(t[e][list(s)])) in inc_faces
    )
    m = len(p)
    p = np.vstack([p, p[t[k][list(face)]].mean(axis=0)])
    pieces = []
    for v in face:  # replace each face vertex by the centroid in turn
        q = t[k].copy()
        q[v] = m
        pieces.append(q)
    t = np.vstack([np.delete(t, k, axis=0), pieces])
    r = np.concatenate([np.delete(r, k), [ped] * 3])
    order = np.argsort(r, kind="stable")
    err = refused(capsys, write_arrays(tmp_path / "hang.msh", p, t[order], r[order], f))
    assert "non-conforming interface between regions" in err and "incus" in err and "pedicle" in err


def test_region_that_touches_nothing(capsys, joint, tmp_path):
    p, t, r, f = uncut(joint)
    p2, t2 = _own_nodes(p, t, r, "pedicle", shift=(0.0, 0.0, 0.01))
    err = refused(capsys, write_arrays(tmp_path / "away.msh", p2, t2, r, f))
    assert "region pedicle touches no other region" in err


def test_over_large_mesh_refused_before_anything_is_built(capsys, files, monkeypatch):
    import isj.fem.user_checks
    import isj.fem.user_mesh

    def never(*a, **k):
        raise AssertionError("built something")

    monkeypatch.setattr(isj.fem.user_mesh, "max_model_bytes", lambda: 2**20)
    monkeypatch.setattr(isj.fem.user_checks, "check_geometry", never)
    msh, _ = files
    err = refused(capsys, msh)
    assert "GiB" in err and "over the" in err and "at least" in err  # the header check, before reading
    monkeypatch.setattr(isj.fem.user_mesh, "msh_node_count", lambda path: None)
    err = refused(capsys, msh)
    assert "3069 tetrahedra" in err and "GiB" in err  # the exact check, before any checks or assembly
    with pytest.raises(InvalidMesh, match="GiB"):
        read_mesh(msh, max_bytes=2**20)


def test_points_file_errors(capsys, files, tmp_path):
    msh, toml = files
    bad = tmp_path / "bad.toml"
    bad.write_text(toml.read_text().replace("[faces.stapes_at_gap]", "[faces.stapes_at_gapp]"))
    err = refused(capsys, msh, "--points", str(bad))
    assert "--points" in err and "stapes_at_gap" in err
    far = tmp_path / "far.toml"
    far.write_text(toml.read_text().replace("0.000455]", "0.0455]"))
    err = refused(capsys, msh, "--points", str(far))
    assert err.startswith("isj: error: --points") and "incus_at_pedicle" in err and "outside" in err


def test_mesh_options_refused(capsys, files, tmp_path):
    msh, toml = files
    assert "not with --mesh" in refused(capsys, msh, "--resolution", "2")
    code, _, err = run(capsys, ["fem", "solve", "--points", str(toml)])
    assert code == 2 and "only with --mesh" in err
    code, _, err = run(capsys, ["fem", "mesh", "--msh", str(tmp_path / "x.vtk")])
    assert code == 2 and "--msh" in err and not (tmp_path / "x.vtk").exists()
    (tmp_path / "junk.msh").write_text("not a mesh\n")
    assert "meshio cannot read it" in refused(capsys, tmp_path / "junk.msh")


@pytest.mark.slow
def test_gmsh_41_tetra10_file_in_micrometres(capsys, tmp_path):
    """What a user's gmsh script writes: format 4.1, second order, µm; α and β as built in."""
    import gmsh
    from isj.fem.geometry import build_pedicle_joint
    from isj.fem.mesh import DEFAULT_GEOMETRY, _configure, _resolve, initialize_gmsh
    from isj.fem.user_model import default_points, points_toml

    path = tmp_path / "own.msh"
    initialize_gmsh(gmsh)
    try:
        _configure(gmsh)
        gmsh.model.add("own")
        build_pedicle_joint(DEFAULT_GEOMETRY, _resolve(None, 0.35))
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
        gmsh.option.setNumber("Mesh.SaveAll", 1)  # meshio 5.3 cannot read this one; gmsh's API can
        gmsh.write(str(tmp_path / "all.msh"))
    finally:
        gmsh.finalize()
    all_elements = read_mesh(tmp_path / "all.msh", unit="um")
    assert all_elements.content_hash() == read_mesh(path, unit="um").content_hash()
    toml = tmp_path / "points.toml"
    toml.write_text(points_toml(default_points()))
    _, out, _ = run(capsys, ["fem", "solve", "--json", "--order", "1", *COARSE])
    built_in = json.loads(out)
    vtu = tmp_path / "own.vtu"
    argv = ["fem", "solve", "--json", "--order", "1", "--mesh", str(path), "--mesh-unit", "um"]
    code, out, err = run(capsys, [*argv, "--points", str(toml), "--vtu", str(vtu)])
    assert code == 0, err
    own = json.loads(out)
    for key in ANGLES:
        assert own[key] == pytest.approx(built_in[key], rel=1e-9)
    assert meshio.read(vtu).cells[0].type == "tetra"
    assert set(own["strain_energy_j"]) == set(REGIONS)


def test_tetra10_corners_are_used_and_curved_ones_warned(joint, tmp_path):
    from isj.fem.elements import TET10_EDGES

    from isj.errors import IsjWarning

    p, t, r, f = uncut(joint)
    n = len(p)
    edges = np.sort(t[:, TET10_EDGES].reshape(-1, 2), axis=1)
    uniq, inv = np.unique(edges[:, 0] * n + edges[:, 1], return_inverse=True)
    lo, hi = np.divmod(uniq, n)
    p10 = np.vstack([p, 0.5 * (p[lo] + p[hi])])
    t10 = np.hstack([t, n + inv.reshape(-1, 6)])
    tri6 = {}
    for name, tri in f.items():
        e = np.sort(tri[:, [[0, 1], [1, 2], [0, 2]]].reshape(-1, 2), axis=1)
        tri6[name] = np.hstack([tri, n + np.searchsorted(uniq, e[:, 0] * n + e[:, 1]).reshape(-1, 3)])
    cells = [("tetra10", t10[r == k]) for k in range(len(REGIONS))] + [
        ("triangle6", v) for v in tri6.values()
    ]
    tags = [np.full(len(c[1]), k + 1) for k, c in enumerate(cells[:6])] + [
        np.full(len(v), 11 + k) for k, v in enumerate(tri6.values())
    ]
    fd = {name: np.array([k + 1, 3]) for k, name in enumerate(REGIONS)} | {
        name: np.array([11 + k, 2]) for k, name in enumerate(tri6)
    }

    def write(path, points):
        meshio.write(
            path,
            meshio.Mesh(
                points, cells, cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags}, field_data=fd
            ),
            file_format="gmsh22",
            binary=False,
        )
        return path

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = read_mesh(write(tmp_path / "t10.msh", p10))
    assert back.content_hash() == joint.content_hash()
    bent = p10.copy()
    bent[n] += 1e-7  # one mid-edge node off its midpoint
    with pytest.warns(IsjWarning, match="mid-edge nodes"):
        read_mesh(write(tmp_path / "bent.msh", bent))


def test_capsule_free_over_the_whole_interface_refused(capsys, joint, tmp_path):
    from isj.fem.user_checks import check_topology

    p, t, r, f = uncut(joint)
    topo = check_topology("x", p, t, r, f)
    f["capsule_free"] = topo.capsule_interface_without(np.empty((0, 3), dtype=np.int64))
    err = refused(capsys, write_arrays(tmp_path / "loose.msh", p, t, r, f))
    assert "capsule would touch nothing" in err


def test_fem_mesh_reports_and_converts_a_user_mesh(capsys, joint, tmp_path):
    p, t, r, f = uncut(joint)
    vtu = write_arrays(tmp_path / "own.vtu", p, t, r, f, file_format="vtu")
    code, out, err = run(
        capsys,
        ["fem", "mesh", "--json", "--order", "1", "--mesh", str(vtu), "--msh", str(tmp_path / "own.msh")],
    )
    assert code == 0, err
    report = json.loads(out.splitlines()[0])
    assert report["mesh_hash"] == joint.content_hash() and report["n_tets"] == joint.n_tets
    assert read_mesh(tmp_path / "own.msh").content_hash() == joint.content_hash()
