"""The whole cat middle ear with the pedicle-and-joint model inside (fem/ear/middle_ear.py, isj/ear.py)."""

import math

import numpy as np
import pytest

pytest.importorskip("gmsh")

from fem.ear.footplate import footplate_mesh  # noqa: E402
from fem.ear.middle_ear import MiddleEarModel, joint_frame  # noqa: E402
from fem.ear.rigid import axis_of_rotation, grounded_springs, point_map  # noqa: E402
from fem.ear.shell import NDOF  # noqa: E402
from fem.model import PedicleJointModel  # noqa: E402
from isj.cases import THESIS_CASES  # noqa: E402
from isj.design import REGIONS, InvalidParameter, Materials  # noqa: E402
from isj.ear import EarGeometry, EarMaterials  # noqa: E402

CAT = EarGeometry()
NO_SPRINGS = EarMaterials(
    malleus_ligament_n_m=0.0,
    incudal_lateral_n_m=0.0,
    incudal_medial_n_m=0.0,
    annular_out_of_plane_n_m=0.0,
    annular_in_plane_n_m=0.0,
)


@pytest.fixture(scope="module")
def joint():
    return PedicleJointModel(order=2, resolution=0.35)


@pytest.fixture(scope="module")
def ear(joint):
    return MiddleEarModel(joint=joint)


@pytest.fixture(scope="module")
def rigid():
    return MiddleEarModel()


def _rigid_motion(model, u0, theta, x0):
    """Full dof vector of one rigid motion (u0, θ) about x0 applied to every part of the ear."""
    u = np.zeros(model.n_full)
    for nodes, off in ((model.drum.nodes_m, model.off_drum), (model.footplate.nodes_m, model.off_fp)):
        g = point_map(nodes, x0)
        blk = np.zeros((len(nodes), NDOF))
        blk[:, :3] = g @ np.concatenate([u0, theta])
        blk[:, 3:] = theta
        u[off : off + NDOF * len(nodes)] = blk.ravel()
    if model.joint is not None:
        R = joint_frame(model.geometry)
        ue = point_map(model.joint_points_m, x0) @ np.concatenate([u0, theta])
        u[model.off_joint : model.off_body] = (ue @ R).ravel()  # Rᵀ u in the joint's frame
    for dofs, x in ((model.body_dofs, model.geometry.body_reference_m), (model.stapes_dofs, None)):
        if x is None:
            if model.joint is None:
                continue
            x = model.geometry.stapes_head_m
        u[dofs[:3]] = point_map(x, x0)[0] @ np.concatenate([u0, theta])
        u[dofs[3:]] = theta
    return u


# --------------------------------------------------------------------------- geometry


def test_cat_defaults_and_derived_positions():
    assert CAT.footplate_area_m2 == 1.26e-6
    a, b = CAT.footplate_semi_axes_m
    assert math.isclose(math.pi * a * b, 1.26e-6) and math.isclose(a / b, CAT.footplate_aspect)
    assert CAT.piston_direction == (0.0, 0.0, -1.0)
    assert np.allclose(np.cross(CAT.joint_x_direction, CAT.joint_y_direction), CAT.joint_z_direction)
    head = np.asarray(CAT.stapes_head_m)
    assert np.allclose(head + CAT.joint_length_m * np.asarray(CAT.joint_z_direction), CAT.long_process_end_m)
    assert 1.5 < CAT.lever_ratio < 3.5


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"crura_height_m": -1e-3}, "crura_height_m"),
        ({"footplate_area_m2": 0.0}, "footplate_area_m2"),
        ({"footplate_aspect": 0.5}, "footplate_aspect"),
        ({"footplate_rim_fraction": 0.7}, "footplate_rim_fraction"),
        ({"annular_springs": 3}, "annular_springs"),
        ({"body_reference_m": (1.0, 2.0)}, "body_reference_m"),
        ({"joint_x_direction": (0.0, 0.0, 1.0)}, "joint_x_direction"),
        ({"joint_z_direction": (0.0, 0.0, 0.0)}, "joint_z_direction"),
        ({"drum_normalized_radius": 0.4}, "drum_normalized_radius"),
        ({"umbo_x_m": 5e-3}, "umbo_x_m"),
    ],
)
def test_bad_geometry_raises_one_line_naming_the_parameter(changes, name):
    with pytest.raises(InvalidParameter) as err:
        EarGeometry(**changes)
    msg = str(err.value)
    assert msg.startswith(name) and "\n" not in msg and "must" in msg


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"drum_e_pa": 0.0}, "drum_e_pa"),
        ({"footplate_nu": 0.5}, "footplate_nu"),
        ({"incudal_medial_n_m": -1.0}, "incudal_medial_n_m"),
    ],
)
def test_bad_materials_raise_naming_the_parameter(changes, name):
    with pytest.raises(InvalidParameter, match=f"^{name}"):
        EarMaterials(**changes)


def test_footplate_mesh_outline_rim_and_crura_band():
    fp = footplate_mesh(CAT)
    out, crura = fp.node_sets["outline"], fp.node_sets["crura"]
    assert out.size == 40 and crura.size >= 30
    x = fp.nodes_m - np.asarray(CAT.footplate_centre_m)
    assert np.allclose(x @ np.asarray(CAT.piston_direction), 0.0, atol=1e-15)  # flat, normal = piston
    # area of the 40-gon inscribed in the ellipse: π a b × sin(2π/40) × 40 / (2π)
    p = fp.nodes_m[fp.triangles]
    area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    assert math.isclose(area, 1.26e-6 * 40 * math.sin(2 * math.pi / 40) / (2 * math.pi), rel_tol=1e-12)
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(normals @ np.asarray(CAT.piston_direction) > 0)
    assert fp.rim.any() and np.all(np.isin(fp.triangles[fp.rim], np.concatenate([out, crura])))


def test_embedded_joint_faces_sit_where_the_geometry_says(ear):
    pts = ear.joint_points_m
    assert np.allclose(pts[ear.stapes_face].mean(axis=0)[[0, 1]], CAT.stapes_head_m[:2], atol=2e-6)
    assert np.allclose(pts[ear.stapes_face][:, 2], CAT.stapes_head_m[2], atol=1e-12)
    assert np.allclose(pts[ear.incus_face][:, 2], CAT.long_process_end_m[2], atol=1e-12)
    assert np.allclose(ear.drum.nodes_m[ear.drum.node_sets["umbo"][0]], CAT.umbo_m, atol=1e-12)


# --------------------------------------------------------------------------- springs and constraints


def test_offset_spring_gives_the_hand_computed_body_stiffness():
    k, h = 2.5e3, 0.4e-3
    K = grounded_springs((0.0, 0.0, 0.0), [(0.0, 0.0, h)], [k * np.diag([1.0, 0.0, 0.0])])
    expected = np.zeros((6, 6))
    # u_x = u_x0 + θ_y h: k (u_x0 + h θ_y)² / 2
    expected[0, 0], expected[0, 4], expected[4, 0], expected[4, 4] = k, k * h, k * h, k * h * h
    assert np.allclose(K, expected, rtol=0, atol=1e-15 * k)


def test_springs_alone_give_the_spec_totals(ear):
    """Rigid translations of the footplate and of the malleus–incus body against the springs alone."""
    K = ear.full_stiffness(ear_materials=EarMaterials())
    K0 = ear.full_stiffness(ear_materials=NO_SPRINGS)
    Ks = K - K0
    for direction, expected in (((0, 0, 1), 40 * 11.0), ((1, 0, 0), 40 * 9.9), ((0, 1, 0), 40 * 9.9)):
        u = np.zeros(ear.n_full)
        blk = np.zeros((len(ear.footplate.nodes_m), NDOF))
        blk[:, :3] = direction
        u[ear.off_fp : ear.off_joint] = blk.ravel()
        assert math.isclose(u @ (Ks @ u), expected, rel_tol=1e-9)  # K − K0: round-off of the shell
    u = np.zeros(ear.n_full)
    u[ear.body_dofs[0]] = 1.0
    assert math.isclose(u @ (Ks @ u), 4e3 / 3 + 10e3 + 30e3, rel_tol=1e-9)


@pytest.mark.parametrize("variant", ["rigid", "ear"])
def test_rigid_motion_is_a_constraint_solution_and_stores_no_energy_without_grounds(variant, request):
    model = request.getfixturevalue(variant)
    u = _rigid_motion(
        model, np.array([1e-6, -2e-6, 3e-6]), np.array([2e-3, -1e-3, 1.5e-3]), (1e-3, 2e-3, -1e-3)
    )
    # the ties reproduce a rigid motion exactly (the clamped ring is the only ground left)
    back = model.T @ u[model.free]
    ring = (6 * model.drum.node_sets["ring"][:, None] + np.arange(6)).ravel()
    mask = np.ones(model.n_full, bool)
    mask[ring] = False
    assert np.allclose(back[mask], u[mask], rtol=0, atol=1e-12 * np.abs(u).max())
    K = model.full_stiffness(ear_materials=NO_SPRINGS)
    scale = np.abs(K.diagonal()) @ (u * u)
    assert abs(u @ (K @ u)) <= 1e-9 * scale


def test_reduced_stiffness_is_symmetric_and_reciprocal(ear):
    K = ear.stiffness(Materials())
    asym = abs(K - K.T).max()
    assert asym <= 1e-12 * abs(K).max()
    f1 = ear.unit_load
    f2 = np.zeros(ear.n_full)
    c = ear.off_fp + NDOF * ear.footplate.node_sets["centre"][0]
    f2[c : c + 3] = 1e-6 * np.asarray(CAT.piston_direction)
    u = ear.solve_reduced(K, np.column_stack([ear.T.T @ f1, ear.T.T @ f2]))
    w12, w21 = f1 @ u[:, 1], f2 @ u[:, 0]
    assert abs(w12) > 0 and math.isclose(w12, w21, rel_tol=1e-8)


def test_load_displacement_is_linear(ear):
    K = ear.stiffness(Materials())
    f = ear.load_reduced
    u1 = ear.solve_reduced(K, f)[:, 0]
    u2 = ear.solve_reduced(K, 2.828 * f)[:, 0]
    for part in (slice(ear.off_drum, ear.off_fp), slice(ear.off_joint, ear.off_body)):
        assert np.linalg.norm(u2[part] - 2.828 * u1[part]) <= 1e-9 * np.linalg.norm(u2[part])
    res = ear.result(u2)
    assert math.isclose(res.umbo_m_per_pa, 2.828 * ear.result(u1).umbo_m_per_pa, rel_tol=1e-9)


# --------------------------------------------------------------------------- responses


def test_rigid_variant_has_a_plausible_response(rigid):
    r = rigid.solve()
    assert r.alpha_rad_per_pa is None
    # medial pressure moves the umbo and the footplate medially (into the cochlea)
    assert r.umbo_vector_m_per_pa[2] < 0 and r.footplate_piston_m_per_pa > 0
    assert r.eardrum_max_m_per_pa >= r.umbo_m_per_pa
    assert 1e-9 < r.footplate_piston_m_per_pa < r.umbo_m_per_pa < 1e-6
    ax = r.rotation_axis
    assert abs(ax["direction"][1]) > 0.8  # about the anteroposterior line of the ligaments
    assert math.isclose(np.linalg.norm(ax["direction"]), 1.0)


def test_stiff_joint_limit_equals_the_rigid_variant(ear, rigid):
    stiff = Materials(**{f"{r}_e_pa": 1e4 * Materials().youngs(r) for r in REGIONS})
    a, b = ear.solve(stiff), rigid.solve()
    for key in ("umbo_vector_m_per_pa", "footplate_m_per_pa"):
        x, y = getattr(a, key), getattr(b, key)
        assert np.linalg.norm(x - y) <= 1e-3 * np.linalg.norm(y)
    assert np.allclose(
        a.body_m_rad_per_pa, b.body_m_rad_per_pa, rtol=1e-3, atol=1e-3 * np.abs(b.body_m_rad_per_pa).max()
    )
    assert abs(a.alpha_rad_per_pa) < 1e-2 * abs(ear.solve(Materials()).alpha_rad_per_pa)


def test_alpha_beta_in_the_ear_are_finite_with_the_isolated_sign(ear, joint):
    iso = joint.solve(Materials())
    r = ear.solve(Materials())
    for name in ("alpha", "beta"):
        v = getattr(r, f"{name}_rad_per_pa")
        assert math.isfinite(v) and v != 0
        assert np.sign(v) == np.sign(getattr(iso, f"{name}_rad"))
        assert np.sign(getattr(r, f"{name}_ls_rad_per_pa")) == np.sign(v)


def test_seven_cases_reuse_one_analysis_and_order_as_expected(ear):
    first = ear.solve(Materials())
    solver = ear._solver
    res = ear.solve_cases()
    assert ear._solver is solver and list(res) == [c.name for c in THESIS_CASES]
    assert res["base"].beta_rad_per_pa == pytest.approx(first.beta_rad_per_pa, rel=1e-10)
    assert res["p3"].beta_rad_per_pa > res["base"].beta_rad_per_pa > res["p12"].beta_rad_per_pa
    assert res["j5"].alpha_rad_per_pa > res["base"].alpha_rad_per_pa
    d = res["base"].to_dict()
    for key in ("umbo_m_per_pa", "eardrum_max_m_per_pa", "alpha_rad_per_pa", "beta_rad_per_pa", "timings_s"):
        assert key in d
    assert len(d["footplate_m_per_pa"]) == 3 and {"point_m", "direction"} <= set(d["rotation_axis"])


def test_axis_of_rotation_recovers_a_known_axis():
    p, d = np.array([1e-3, 2e-3, -1e-3]), np.array([0.0, 0.6, 0.8])
    theta = 1e-5 * d
    x0 = np.array([4e-3, 0.0, 0.0])
    u0 = np.cross(theta, x0 - p) + 3e-10 * d  # plus a small slide along the axis
    ax = axis_of_rotation(u0, theta, x0)
    foot = np.asarray(ax["point_m"])
    assert np.allclose(np.cross(foot - p, d), 0.0, atol=1e-15)  # on the axis
    assert np.allclose(ax["direction"], d) and math.isclose(ax["axial_translation_m"], 3e-10)


# --------------------------------------------------------------------------- command line


def test_cli_ear_solve_json_and_bad_input(capsys):
    import json

    from isj.cli import main

    assert main(["ear", "solve", "--rigid-joint", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["umbo_m_per_pa"] > 0 and len(out["footplate_m_per_pa"]) == 3
    assert main(["ear", "solve", "--drum-e", "-3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("isj: error:") and "--drum-e" in err and "\n" not in err
