"""The whole cat middle ear with the pedicle-and-joint model inside (fem/ear/middle_ear.py, isj/ear.py)."""

import math

import gmsh  # noqa: F401 - a hard dependency: without it these tests fail, they do not skip
import numpy as np
import pytest
from isj.fem.ear.footplate import footplate_mesh
from isj.fem.ear.middle_ear import MiddleEarModel, joint_frame
from isj.fem.ear.rigid import axis_of_rotation, grounded_springs, point_map
from isj.fem.ear.shell import NDOF
from isj.fem.model import PedicleJointModel

from isj.cases import THESIS_CASES
from isj.design import REGIONS, Materials
from isj.ear import EarGeometry, EarMasses, EarMaterials
from isj.errors import InvalidParameter

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
    r = rigid.static()
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
    a, b = ear.static(stiff), rigid.static()
    for key in ("umbo_vector_m_per_pa", "footplate_m_per_pa"):
        x, y = getattr(a, key), getattr(b, key)
        assert np.linalg.norm(x - y) <= 1e-3 * np.linalg.norm(y)
    assert np.allclose(
        a.body_m_rad_per_pa, b.body_m_rad_per_pa, rtol=1e-3, atol=1e-3 * np.abs(b.body_m_rad_per_pa).max()
    )
    assert abs(a.alpha_rad_per_pa) < 1e-2 * abs(ear.static(Materials()).alpha_rad_per_pa)


def test_alpha_beta_in_the_ear_are_finite_with_the_isolated_sign(ear, joint):
    iso = joint.static(Materials())
    r = ear.static(Materials())
    for name in ("alpha", "beta"):
        v = getattr(r, f"{name}_rad_per_pa")
        assert math.isfinite(v) and v != 0
        assert np.sign(v) == np.sign(getattr(iso, f"{name}_rad"))
        assert np.sign(getattr(r, f"{name}_ls_rad_per_pa")) == np.sign(v)


@pytest.mark.slow
def test_seven_cases_reuse_one_analysis_and_order_as_expected(ear):
    first = ear.static(Materials())
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


# --------------------------------------------------------------------------- dynamics (docs/ear.md §5.11)
#
# Measured on the default anatomy (rigid joint; the coarse embedded joint agrees to 0.2 %):
# the lowest FE natural frequencies are eardrum modes, 1656, 1902, 2017 Hz (98, 99, 93 % of
# their kinetic energy in the drum); undamped at 1 Hz the response differs from the static one
# by ≈ 4e-7 relative ((1 Hz / 1.66 kHz)² scale).


def _ear_dynamics():
    from isj.fem.ear import dynamics as ear_dynamics

    return ear_dynamics


def _expected_total_mass(model, materials=None):
    """ρ t A of the drum, the two bodies' masses (the footplate is part of the 0.5 mg stapes), ρ V of
    the joint's regions."""
    from isj.fem.ear.shell import surface_area
    from isj.fem.quality import tet_quality

    ms, em = EarMasses(), EarMaterials()
    total = (
        ms.drum_density_kg_m3 * em.drum_thickness_m * surface_area(model.drum.nodes_m, model.drum.triangles)
    )
    total += ms.malleus_incus_kg + ms.stapes_kg
    if model.joint is not None:
        mesh = model.joint.mesh
        m = materials or Materials()
        for name in mesh.region_names:
            vol = np.abs(tet_quality(mesh.points, mesh.region_tets(name))["volume"]).sum()
            total += m.density(name) * vol
    return total


@pytest.mark.parametrize("variant", ["rigid", "ear"])
def test_unit_translation_kinetic_energy_is_the_total_mass(variant, request):
    from isj.fem.ear.shell import surface_area

    model = request.getfixturevalue(variant)
    ed = _ear_dynamics()
    M_full, Mr = ed.full_mass(model), model.mass()
    expected = _expected_total_mass(model)
    fp, g, ms = model.footplate, model.geometry, EarMasses()
    fp_area_mass = sum(
        ms.footplate_density_kg_m3 * t * surface_area(fp.nodes_m, tris)
        for tris, t in (
            (fp.triangles[~fp.rim], g.footplate_centre_thickness_m),
            (fp.triangles[fp.rim], g.footplate_rim_thickness_m),
        )
    )
    assert ed.stapes_rigid_mass(model)["footplate_kg"] == pytest.approx(fp_area_mass, rel=1e-12)
    for d in np.eye(3):  # the ring is clamped: a rigid motion of the unconstrained ear
        u = _rigid_motion(model, d, np.zeros(3), np.asarray(CAT.body_reference_m))
        assert u @ (M_full @ u) == pytest.approx(expected, rel=1e-10)
    q = np.random.default_rng(1).standard_normal(model.n_dofs)  # the reduction: qᵀ M_r q = uᵀ M u
    u = model.T @ q
    assert q @ (Mr @ q) == pytest.approx(u @ (M_full @ u), rel=1e-10)


def test_stapes_mass_split_keeps_the_lumped_mass_and_centroid(rigid):
    st = _ear_dynamics().stapes_rigid_mass(rigid)
    fe, lum = st["fe_6x6"], st["lumped_6x6"]
    assert 0.15e-6 < st["footplate_kg"] < 0.3e-6  # ≈ 0.21 mg of the 0.5 mg stapes
    np.testing.assert_allclose(fe[:3], lum[:3], rtol=0, atol=1e-12 * lum[0, 0])  # mass, first moment
    # rotary inertia differs (the footplate's is anisotropic): documented, not equal
    assert np.all(np.diag(fe)[3:] > np.diag(lum)[3:])


@pytest.mark.parametrize("variant", ["rigid", "ear"])
def test_reduced_mass_is_symmetric_and_on_the_stiffness_pattern(variant, request):
    model = request.getfixturevalue(variant)
    M, K = model.mass(), model.stiffness()
    assert np.array_equal(M.indptr, K.indptr) and np.array_equal(M.indices, K.indices)
    assert abs(M - M.T).max() <= 1e-13 * abs(M).max()


@pytest.mark.parametrize("variant", ["rigid", "ear"])
def test_undamped_response_at_1_hz_is_the_static_one(variant, request):
    model = request.getfixturevalue(variant)
    ed = _ear_dynamics()
    r = ed.harmonic(model, 1.0, damping=ed.Damping.preset("undamped"))
    s = r.static
    assert r.umbo_m_per_pa[0] == pytest.approx(s.umbo_m_per_pa, rel=1e-6)
    assert r.stapes_m_per_pa[0] == pytest.approx(s.footplate_piston_m_per_pa, rel=1e-6)
    np.testing.assert_allclose(r.footplate_m_per_pa[0], s.footplate_m_per_pa, rtol=1e-6, atol=0)
    if model.joint is not None:
        assert r.alpha_rad_per_pa[0] == pytest.approx(s.alpha_rad_per_pa, rel=1e-6)
        assert r.beta_rad_per_pa[0] == pytest.approx(s.beta_rad_per_pa, rel=1e-6)
    assert abs(r.umbo_m_per_pa[0].imag) == 0.0  # undamped: real


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["rigid", "ear"])
def test_loss_factor_alone_divides_the_static_response(variant, request):
    model = request.getfixturevalue(variant)
    ed = _ear_dynamics()
    eta = 0.3
    r = ed.harmonic(model, 0.0, damping=ed.Damping.uniform(loss_factor=eta))
    s = r.static
    expected = np.array([s.umbo_m_per_pa, s.footplate_piston_m_per_pa]) / (1 + 1j * eta)
    np.testing.assert_allclose(r.outputs()[0, :2], expected, rtol=1e-9)
    if model.joint is not None:
        assert r.alpha_rad_per_pa[0] == pytest.approx(s.alpha_rad_per_pa / (1 + 1j * eta), rel=1e-9)
    # Rayleigh b alone at 1 Hz: static / (1 + iωb) up to the inertia term (≈ 4e-7)
    b = 1e-4
    r = ed.harmonic(model, 1.0, damping=ed.Damping.uniform(rayleigh_b_s=b))
    assert r.umbo_m_per_pa[0] == pytest.approx(s.umbo_m_per_pa / (1 + 2j * np.pi * b), rel=2e-6)


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["rigid", "ear"])
def test_natural_frequencies_positive_and_modes_mass_orthonormal(variant, request):
    model = request.getfixturevalue(variant)
    modes = _ear_dynamics().natural_frequencies(model, 4)
    f = modes.freq_hz
    assert np.array_equal(model.natural_frequencies_hz(4), f)
    assert np.all(f > 0) and np.all(np.diff(f) >= 0)
    assert 1000 < f[0] < 3000  # measured 1656 Hz (rigid), 1653 Hz (coarse joint)
    V, M, K = modes.shapes_reduced, model.mass(), model.stiffness()
    np.testing.assert_allclose(V.T @ (M @ V), np.eye(4), atol=1e-8)
    np.testing.assert_allclose(
        V.T @ (K @ V), np.diag((2 * np.pi * f) ** 2), rtol=1e-8, atol=1e-6 * f[-1] ** 2
    )


def test_rigid_harmonic_solve_is_fast_and_decays_above_resonance(rigid):
    r = _ear_dynamics().harmonic(rigid, [100.0, 20e3])
    assert r.timings_s["per_frequency"] < 2.0  # measured 0.04 s (5k dofs)
    assert abs(r.umbo_m_per_pa[1]) < 0.1 * abs(r.umbo_m_per_pa[0])


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda m, ed: m.frequency_response(-1.0), "freq_hz"),
        (lambda m, ed: m.frequency_response([]), "freq_hz"),
        (lambda m, ed: ed.Damping(rayleigh_b_s=-1.0), "rayleigh_b_s"),
        (lambda m, ed: ed.Damping(loss_factor=float("nan")), "loss_factor"),
        (lambda m, ed: m.natural_frequencies_hz(0), "n"),
        (lambda m, ed: m.mass(masses=EarMasses(stapes_kg=1e-8)), "stapes_kg"),
    ],
)
def test_bad_dynamics_parameters_raise_naming_them(rigid, call, name):
    with pytest.raises(InvalidParameter, match=name):
        call(rigid, _ear_dynamics())


@pytest.mark.parametrize(
    "changes, name",
    [
        ({"stapes_kg": -1.0}, "stapes_kg"),
        ({"drum_density_kg_m3": float("inf")}, "drum_density_kg_m3"),
        ({"stapes_centroid_fraction": 1.5}, "stapes_centroid_fraction"),
        ({"malleus_incus_centroid_m": (1.0, 2.0)}, "malleus_incus_centroid_m"),
    ],
)
def test_bad_masses_raise_naming_the_parameter(changes, name):
    with pytest.raises(InvalidParameter, match=name):
        EarMasses(**changes)
