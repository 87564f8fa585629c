"""The joint as a sliding interface (docs/model.md §2.12): patch tests, energy, the seven cases."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from isj.fem.assembly import assemble_regions, build_pattern, combine, lame_unit
from isj.fem.boundary import Reduction, traction_load
from isj.fem.mesh import TetMesh
from isj.fem.sliding import TiedReduction, shear_split
from isj.fem.space import build_space
from isj.fem.structured import box_mesh

from isj.cases import THESIS_CASES
from isj.design import Materials
from isj.errors import InvalidParameter

L, H = 1e-3, 0.5e-3  # block side and height (m)
E = {"lower": 1e9, "upper": 3e9}  # Pa: unequal, so bonding would restrain the lateral strains
NU = 0.3


def two_blocks(bonded: bool) -> TetMesh:
    """Two L × L × H blocks stacked in z; the interface z = H is cut open unless ``bonded``."""
    lo = box_mesh((L, L, H), (2, 2, 2))
    up = box_mesh((L, L, H), (2, 2, 2), origin_m=(0.0, 0.0, H))
    n = lo.n_nodes
    points = np.vstack([lo.points, up.points])
    tets = np.vstack([lo.tets, up.tets + n])
    faces = {
        "bottom": lo.faces["z0"],
        "top": up.faces["z1"] + n,
        "x0": np.vstack([lo.faces["x0"], up.faces["x0"] + n]),
        "y0": np.vstack([lo.faces["y0"], up.faces["y0"] + n]),
        "upper_x1": up.faces["x1"] + n,
        "upper_y0": up.faces["y0"] + n,
    }
    if bonded:  # merge the upper block's interface nodes into the lower block's
        key = lambda p: np.round(p / L * 1e6).astype(np.int64)  # noqa: E731
        _, first, inv = np.unique(key(points), axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first)
        new = np.empty(order.size, np.int64)
        new[order] = np.arange(order.size)
        remap = new[inv.ravel()]
        points = points[np.sort(first)]
        tets = remap[tets]
        faces = {k: remap[v] for k, v in faces.items()}
    region = np.repeat(np.array([0, 1], np.int8), [lo.n_tets, up.n_tets])
    return TetMesh(points, tets, region, ("lower", "upper"), faces)


def solve_blocks(bonded: bool, traction, fixed: dict[str, tuple[int, ...]], order: int = 2):
    """Solve the two blocks: ``fixed`` maps face → the components held at zero."""
    space = build_space(two_blocks(bonded), order)
    pattern = build_pattern(space)
    regions = assemble_regions(space, pattern)
    lam, mu = lame_unit(NU)
    data = combine(pattern, regions, {r: (E[r] * lam, E[r] * mu) for r in regions})
    K = pattern.matrix(data)
    dofs = [3 * space.face_nodes(f)[:, None] + np.array(c) for f, c in fixed.items()]
    held = np.unique(np.concatenate([d.ravel() for d in dofs]))
    if bonded:
        red = Reduction.build(pattern, held)
    else:  # pair the upper block's interface nodes with the lower's; tie u_z only
        z = space.points[:, 2]
        on = np.isclose(z, H, rtol=0, atol=1e-9 * L)
        used = [np.isin(np.arange(space.n_nodes), space.cells[space.region == r]) for r in (0, 1)]
        sides = [np.flatnonzero(on & used[r]) for r in (0, 1)]
        lo, up = (s[np.lexsort(space.points[s, :2].T)] for s in sides)
        assert np.allclose(space.points[lo], space.points[up])
        red = TiedReduction(pattern, held, 3 * up + 2, 3 * lo + 2)
    f = traction_load(space, "top", traction)
    u = red.expand(spla.spsolve(red.matrix(data).tocsc(), red.restrict(f)))
    return space, K, f, u


@pytest.mark.parametrize("order", [1, 2])
def test_patch_normal_traction_transmits_exactly(order):
    """Uniaxial compression on rollers: sliding reproduces the piecewise-uniform exact field."""
    p = 1e4
    rollers = {"bottom": (2,), "x0": (0,), "y0": (1,)}

    def exact(space):  # piecewise uniform: each block contracts in z and expands freely sideways
        x, y, z = space.points.T
        upper = np.zeros(space.n_nodes, bool)
        upper[space.cells[space.region == 1]] = True
        e = np.where(upper & (z > H * (1 - 1e-9)), E["upper"], E["lower"])
        uz = np.where(z <= H, -p * z / E["lower"], -p * H / E["lower"] - p * (z - H) / E["upper"])
        return np.stack([NU * p * x / e, NU * p * y / e, uz], axis=1)

    space, K, f, u = solve_blocks(False, (0.0, 0.0, -p), rollers, order)
    ref = exact(space)
    assert np.abs(u.reshape(-1, 3) - ref).max() < 1e-9 * np.abs(ref).max()
    reaction = (K @ u - f).reshape(-1, 3)[space.face_nodes("bottom"), 2].sum()
    assert reaction == pytest.approx(p * L * L, rel=1e-10)
    # bonded, the unequal lateral strains are restrained: the exact field is not reproduced
    space_b, _, _, u_b = solve_blocks(True, (0.0, 0.0, -p), rollers, order)
    ref_b = exact(space_b)
    assert np.abs(u_b.reshape(-1, 3) - ref_b).max() > 1e-2 * np.abs(ref_b).max()


def test_patch_tangential_traction_transmits_nothing():
    """Shear on the upper block, held at its own side: the lower block's tangential reaction is 0."""
    tau = 1e4
    fixed = {"bottom": (0, 1, 2), "upper_x1": (0,), "upper_y0": (1,)}
    out = {}
    for bonded in (False, True):
        space, K, f, u = solve_blocks(bonded, (tau, 0.0, 0.0), fixed)
        r = (K @ u - f).reshape(-1, 3)[space.face_nodes("bottom")]
        out[bonded] = r.sum(axis=0) / (tau * L * L)
    assert np.abs(out[False][:2]).max() < 1e-10
    assert abs(out[True][0]) > 0.05  # bonded, the lower block takes part of it


@pytest.mark.parametrize(
    "traction,fixed",
    [
        ((1e4, 0.0, -1e4), {"bottom": (0, 1, 2), "upper_x1": (0,), "upper_y0": (1,)}),
        ((0.0, 0.0, -1e4), {"bottom": (2,), "x0": (0,), "y0": (1,)}),
    ],
)
def test_release_never_lowers_the_compliance(traction, fixed):
    """W = ½ fᵀu = ½ uᵀKu, and W_sliding ≥ W_bonded (a released constraint)."""
    w = {}
    for bonded in (True, False):
        _, K, f, u = solve_blocks(bonded, traction, fixed)
        w[bonded] = 0.5 * f @ u
        assert 0.5 * u @ (K @ u) == pytest.approx(w[bonded], rel=1e-10)
    assert w[False] >= w[True] * (1 - 1e-12)


@pytest.fixture(scope="module")
def sliding_model():
    from isj.fem.model import PedicleJointModel

    return PedicleJointModel(order=2, resolution=0.35, joint="sliding")


@pytest.fixture(scope="module")
def layer_model():
    from isj.fem.model import PedicleJointModel

    return PedicleJointModel(order=2, resolution=0.35, joint="layer")


def test_bonded_default_is_unchanged(coarse_model):
    from isj.fem.boundary import Reduction as R
    from isj.fem.model import PedicleJointModel

    m = PedicleJointModel(order=2, resolution=0.35, joint="bonded")
    assert isinstance(m.reduction, R) and m.mesh.content_hash() == coarse_model.mesh.content_hash()
    a, b = coarse_model.static(), m.static()
    assert (a.alpha_rad, a.beta_rad, a.alpha_ls_rad) == (b.alpha_rad, b.beta_rad, b.alpha_ls_rad)


def test_sliding_interface_is_tied_in_z_only(sliding_model):
    from isj.fem.sliding import tied_nodes

    m = sliding_model
    g, p = tied_nodes(m.space, m.geometry)
    u = m.static().displacement_m
    assert np.array_equal(u[g, 2], u[p, 2])  # normal displacement continuous, exactly
    jump = np.abs(u[g, 0] - u[p, 0]).max()
    assert jump > 0.01 * np.abs(u[p, 0]).max()  # tangential free: the faces slide


@pytest.mark.slow
def test_seven_cases_bonded_against_sliding(coarse_model, sliding_model, layer_model):
    """Energy balance, release raises the compliance, the capsule takes the whole shear."""
    layer = layer_model
    rise = {}
    for case in THESIS_CASES:
        m = case.materials()
        res = {j: model.static(m) for j, model in (("b", coarse_model), ("s", sliding_model), ("l", layer))}
        w = {}
        for j, model in (("b", coarse_model), ("s", sliding_model), ("l", layer)):
            r = res[j]
            w[j] = 0.5 * (model.unit_load * r.pressure_pa) @ r.displacement_m.ravel()
            assert sum(r.strain_energy_j.values()) == pytest.approx(w[j], rel=1e-8)
            split = shear_split(model, r)
            assert split["capsule_shear_share"] + split["gap_shear_share"] == pytest.approx(1, abs=1e-8)
            assert split["capsule_moment_share"] + split["gap_moment_share"] == pytest.approx(1, abs=1e-8)
            if j == "s":
                assert split["capsule_shear_share"] == pytest.approx(1, abs=1e-8)
            if j == "b":
                assert 0.05 < split["capsule_shear_share"] < 0.6
        assert w["s"] > w["b"] and w["l"] > w["b"]
        # a freed joint rotates more (the bodies' rotations), so β/α falls ...
        b, s_ = res["b"], res["s"]
        assert s_.alpha_ls_rad > b.alpha_ls_rad
        assert s_.beta_ls_rad / s_.alpha_ls_rad < b.beta_ls_rad / b.alpha_ls_rad
        # ... but little: the moment is carried by normal stress, which the interface still transmits
        assert s_.alpha_rad == pytest.approx(b.alpha_rad, rel=0.03)
        assert s_.beta_rad == pytest.approx(b.beta_rad, rel=0.01)
        # the layer frees the gap's shear on both faces: a softer joint, a smaller β/α
        assert res["l"].alpha_rad > res["b"].alpha_rad and res["l"].ratio < res["b"].ratio
        rise[case.name] = w["s"] / w["b"]
    # the capsule now carries the shear: the softer it is, the more the release costs
    assert rise["c20"] > rise["base"] > rise["c100"]


def test_joint_is_checked():
    from isj.fem.model import PedicleJointModel

    with pytest.raises(InvalidParameter, match="joint"):
        PedicleJointModel(order=1, resolution=0.35, joint="glued")
    with pytest.raises(InvalidParameter, match="layer_shear_pa"):
        PedicleJointModel(order=1, resolution=0.35, joint="layer", layer_shear_pa=0.0)


def test_cli_joint_json(capsys):
    import json

    from isj.cli import main

    assert main(["fem", "solve", "--json", "--order", "1", "--resolution", "0.35", "--joint", "sliding"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["joint"] == "sliding" and d["capsule_shear_share"] == pytest.approx(1, abs=1e-8)
    assert main(["fem", "solve", "--joint", "glued"]) == 2
    assert "--joint" in capsys.readouterr().err


@pytest.mark.slow
def test_layer_shear_modulus_interpolates(coarse_model, layer_model):
    """A layer as stiff in shear as the cartilage is the bonded gap; softer layers flex more."""
    mu = Materials().gap_e_pa * lame_unit(Materials().nu)[1]
    default = layer_model.layer_shear_pa
    a = []
    try:
        for g in (mu, 1e5, default):
            layer_model.layer_shear_pa = g
            a.append(layer_model.static().alpha_rad)
    finally:
        layer_model.layer_shear_pa = default
    assert a[0] == pytest.approx(coarse_model.static().alpha_rad, rel=1e-10)
    assert a[0] < a[1] < a[2]


def test_the_whole_ear_takes_the_sliding_joint():
    """Inside the ear the cut gap-plate face keeps u_z continuous; releasing never stiffens the ear."""
    from isj.fem.ear.middle_ear import MiddleEarModel
    from isj.fem.model import PedicleJointModel
    from isj.fem.sliding import tied_nodes

    work = {}
    for j in ("bonded", "sliding"):
        jm = PedicleJointModel(order=1, resolution=0.35, joint=j)
        ear = MiddleEarModel(joint=jm)
        u = ear.solve_reduced(ear.stiffness(), ear.load_reduced)[:, 0]
        # W = ½ fᵀu = ½ fᵣᵀ q (fᵣ = Tᵀ f, u = T q), the work of the pressure per Pa²
        q = np.asarray(ear._solver.solve(ear.load_reduced)).ravel()
        work[j] = 0.5 * float(np.asarray(ear.load_reduced).ravel() @ q)
        if j == "sliding":
            uj = ear.joint_displacement(u).reshape(-1, 3)
            gap, plate = tied_nodes(jm.space, jm.geometry)
            np.testing.assert_array_equal(uj[gap, 2], uj[plate, 2])  # the tie, exactly
            assert np.abs(uj[gap, 0] - uj[plate, 0]).max() > 1e-6 * np.abs(uj[:, 0]).max()  # x slides
    assert work["sliding"] >= work["bonded"] * (1 - 1e-12)
